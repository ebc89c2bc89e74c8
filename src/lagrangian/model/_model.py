"""The Model: coordinates, parameters, inputs, elements and explicit energies.

A Model is a description that you build step by step (in Python or from a model file);
:func:`lagrangian.derive` takes a snapshot of it and returns immutable
:class:`~lagrangian.equations.Equations`.
"""

from __future__ import annotations

import copy
import math
import numbers
from typing import Mapping, Sequence

import sympy

from .._util import did_you_mean, shown_value
from ..errors import ExpressionError, ModelError, Problem
from ._constraints import HOLONOMIC, VELOCITY, Constraint
from ._elements import (SPRING_ACTS, Damper, Element, Force, Gravity, Particle, Point, RigidBody, RigidBody3D,
                        RotationalDamper, Shape, Spring, Torque, Torque3D, shape_problems)
from ._frames import AXES, WORLD, Factor, Frame, frame_pose, world_factors
from ._symbols import check_name, ddot, dot, t
from ._wheels import WHEEL_SHAPES, Wheel, ellipsoid_conditions, rolling_conditions

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
        A value may be an expression of other parameters (``{"lA": "(l + r)/2"}``): a derived
        parameter (see :meth:`parameter`), in any order (resolved by dependency; a cycle is refused).
    inputs : sequence of str, optional
        Names of external inputs (forces, torques, signals) that may appear in V, D and Q.
    T, V, D : expression, optional
        Kinetic co-energy, potential energy and dissipation function (SymPy expressions,
        numbers, or strings in the model-file syntax).
    Q : mapping of coordinate name to expression, optional
        Generalized forces not already in D.
    description : str, optional
    outputs : mapping of str to expression, optional
        Named output expressions of the state (see :meth:`add_output`).

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
                 Q: Mapping[str, object] | None = None, description: str = "",
                 outputs: Mapping[str, object] | None = None):
        self.name = name
        self.description = description
        self._coordinates: list[sympy.Symbol] = []
        self._parameters: dict[sympy.Symbol, float | None] = {}
        self._derived: dict[str, sympy.Expr] = {}  # derived parameters: name -> expression of the others
        self._inputs: list[sympy.Symbol] = []
        self._elements: list[Element] = []
        self._frames: dict[str, Frame] = {}
        self._constraints: list[Constraint] = []
        self._wheels: list[Wheel] = []
        self._joints: dict = {}
        self._T = sympy.Integer(0)
        self._V = sympy.Integer(0)
        self._D = sympy.Integer(0)
        self._Q: dict[sympy.Symbol, sympy.Expr] = {}
        self._outputs: dict[str, sympy.Expr] = {}
        self.simulation: dict = {}
        #: The state to linearize about when none is given: coordinate or velocity name -> an
        #: expression of the parameters (a bicycle at speed v: {"thetaR_dot": -v/rR}).
        self.operating_point: dict = {}
        #: The validated [optimal_control] table (io._optimal), the problem lagrangian.optimal_motion solves.
        self.optimal_control: dict = {}
        self._naming_problems: list[Problem] = []
        for what, given, example in (("coordinates", coordinates, "coordinates=['x', 'theta']"),
                                     ("inputs", inputs, "inputs=['F']")):
            if isinstance(given, (str, bytes)) or not hasattr(given, "__iter__"):
                raise ModelError(f"{what} must be a list of names, such as {example}, got {type(given).__name__} "
                                 f"{shown_value(given)}")
        if parameters is not None and not isinstance(parameters, Mapping):
            raise ModelError(f"parameters must be a mapping of names to values, such as parameters={{'m': 1.0, "
                             f"'g': 9.81}}, got {type(parameters).__name__} {shown_value(parameters)}")
        for c in coordinates:
            self.coordinate(c)
        parameters = dict(parameters or {})
        for p in derived_order(parameters):
            self.parameter(p, parameters[p])
        for u in inputs:
            self.input(u)
        self.add_energy(T=T, V=V, D=D)
        for qname, expr in (Q or {}).items():
            self.add_generalized_force(qname, expr)
        for oname, expr in (outputs or {}).items():
            self.add_output(oname, expr)

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

    def parameter(self, name: str, value: float | str | sympy.Expr | None = None) -> sympy.Expr:
        """Declare a named constant with its value (SI units, radians); returns its symbol.

        A `value` that is an expression of other parameters (a string in the model-file syntax such
        as ``"(l + r)/2"``, or a SymPy expression of their symbols) declares a *derived parameter*:
        it is not a free parameter (it has no symbol of its own and is not among :attr:`parameters`,
        nor in the parameters of the equations, of fit or linearize); every expression that names it
        uses its expression instead, so that a new value of ``l`` (``params={"l": 2.0}`` at
        simulate time) changes it too. Returns that expression. It may name only parameters declared
        before it (in a model file or the `parameters` mapping: in any order)."""
        if isinstance(value, (str, sympy.Basic)) and not (isinstance(value, sympy.Basic) and value.is_Number
                                                          or isinstance(value, str) and _is_number_text(value)):
            return self._derived_parameter(name, value)  # a number in quotes is refused below, as in a model file
        if isinstance(value, sympy.Basic):
            value = float(value)
        self._check_new_name(name, "parameter")
        if value is not None and (not isinstance(value, numbers.Real) or isinstance(value, bool)
                                  or not math.isfinite(value)):
            raise ModelError(f"parameter '{name}': the value must be a finite real number, got {value!r}")
        s = sympy.Symbol(name)
        self._parameters[s] = None if value is None else float(value)
        return s

    def _derived_parameter(self, name: str, value) -> sympy.Expr:
        from ._expr import identifiers

        self._check_new_name(name, "parameter")
        where = f"parameters.{name}"
        if isinstance(value, str):
            try:
                used = {n for n, _ in identifiers(value)}
            except ExpressionError as exc:
                raise ModelError([Problem(str(exc), key=where)]) from None
            if name in used:
                raise ModelError([Problem(f"the parameter '{name}' = {value!r} refers to itself: a derived parameter "
                                          "is an expression of other parameters; give it a number, or write it with "
                                          "the others only", key=where)])
            known = set(self._all_names()) | {"t", "pi"} | {dot(c).name for c in self._coordinates}
            unknown = [n for n in dict.fromkeys(u for u, _ in identifiers(value)) if n not in known]
            if unknown:
                params = [p.name for p in self._parameters] + list(self._derived)
                raise ModelError([Problem(f"the parameter '{name}' = {value!r} uses {', '.join(unknown)}, which is "
                                          f"not a parameter{did_you_mean(unknown[0], params)}: a derived parameter is "
                                          "an expression of the other parameters: declare "
                                          f"{unknown[0]} under [parameters] with a value, or give '{name}' a number",
                                          key=where)])
        expr = self.expr(value, where)
        symbols = set(self._parameters)
        others = sorted((s.name for s in expr.free_symbols if s not in symbols), key=str)
        if others:
            raise ModelError([Problem(f"a derived parameter is an expression of other parameters, but '{name}' uses "
                                      f"{', '.join(others)} (not a parameter: a coordinate, velocity, input or t "
                                      "varies); write it with parameters and numbers only", key=where)])
        values = {p: v for p, v in self._parameters.items() if v is not None}
        if expr.free_symbols <= set(values):
            number = complex(expr.xreplace({p: sympy.Float(v) for p, v in values.items()}).evalf())
            if not (math.isfinite(number.real) and abs(number.imag) <= 1e-12 * (1 + abs(number.real))):
                shown = f"{number.real:g}" if number.imag == 0 else f"{number:g}"
                raise ModelError([Problem(f"the parameter '{name}' = {expr} is not a finite real number at the "
                                          f"parameters' values ({shown}): check the expression and the values it "
                                          "uses", key=where)])
        self._derived[name] = expr
        return expr

    @property
    def derived_parameters(self) -> dict[str, sympy.Expr]:
        """The derived parameters: name -> their expression of the (free) parameters."""
        return dict(getattr(self, "_derived", {}))

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

    @property
    def constraints(self) -> tuple[Constraint, ...]:
        """The constraints, in the order they were added."""
        return tuple(self._constraints)

    @property
    def wheels(self) -> tuple[Wheel, ...]:
        """The rolling wheels (each adds its constraints to :attr:`constraints`)."""
        return tuple(self._wheels)

    @property
    def frames(self) -> dict[str, Frame]:
        """The reference frames by name (the inertial frame ``world`` is implicit)."""
        return dict(self._frames)

    @property
    def joints(self) -> dict:
        """The joints by name (:class:`~lagrangian.model._joints.Joint`), in the order they were added."""
        return dict(getattr(self, "_joints", {}))

    def symbol(self, name: str) -> sympy.Symbol:
        """The symbol of a declared name (coordinate, velocity, parameter, input or t)."""
        known = self.names()
        if name not in known:
            raise ModelError(f"model '{self.name}' has no symbol '{name}'{did_you_mean(name, known)}")
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
        names |= {c.multiplier.name for c in getattr(self, "_constraints", ())} | set(getattr(self, "_outputs", ()))
        return names | {u.name for u in self._inputs} | set(getattr(self, "_derived", ()))

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
            from ._expr import parse_expression

            try:
                return parse_expression(value, {**self.names(), **getattr(self, "_derived", {}),
                                                **self._point_components()})
            except ExpressionError as exc:
                raise ModelError([Problem(str(exc), key=where)]) from None
        raise ModelError(f"{where}: expected an expression, a number or a string, got {value!r} "
                         f"({type(value).__name__})")

    def _vector(self, value, where: str, frame: str | None = None) -> tuple[sympy.Expr, ...]:
        """A position (components, or a point's name); with `frame`, components in that frame,
        returned in world coordinates."""
        if isinstance(value, str) and value in self._points():
            if frame is not None:
                raise ModelError(f"{where}: '{value}' is a point's name: it has a position already, so "
                                 "give no frame with it")
            return self._points()[value]
        if frame is not None:
            local = self._vector(value, where)
            if len(local) != 3:
                raise ModelError(f"{where}: a position in the frame '{frame}' has 3 components (x, y, z), "
                                 f"got {len(local)}")
            origin, R = frame_pose(self._frames, self._frame_name(frame, f"{where} (frame)"))
            return tuple(o + r for o, r in zip(origin, R * sympy.Matrix(local)))
        if isinstance(value, (sympy.Matrix, sympy.ImmutableMatrix)):
            value = list(value)
        if not isinstance(value, (list, tuple)) or len(value) not in (2, 3):
            raise ModelError(f"{where}: expected a position with 2 or 3 components "
                             f"(x, y) or (x, y, z), or the name of a point, got {value!r}")
        return tuple(self.expr(v, f"{where}[{i}]") for i, v in enumerate(value))

    def _point_components(self) -> dict[str, sympy.Expr]:
        """``"<point>.x"`` (``.y``, ``.z``) -> that component of each point's, particle's and body's position:
        names that an expression (an energy, a force, an output) may use."""
        return {f"{name}.{axis}": c for name, position in self._points().items()
                for axis, c in zip("xyz", position)}

    def _points(self) -> dict[str, tuple]:
        return {e.name: e.position for e in self._elements if hasattr(e, "position")
                and isinstance(e, (Particle, RigidBody, RigidBody3D, Point))}

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
    def add_point(self, name: str, position, *, frame: str | None = None) -> Point:
        """A massless named point (a pivot, an attachment) that springs and loads can refer to;
        with `frame`, `position` is given in that frame (a body-fixed point)."""
        e = Point(self._unique_element_name(name, "point"),
                  self._vector(position, f"point '{name}'.position", frame))
        self._elements.append(e)
        return e

    def add_particle(self, mass, position, *, frame: str | None = None, name: str | None = None) -> Particle:
        """A point mass at `position`: a 2- or 3-tuple of expressions of q and t (in the axes and
        from the origin of `frame`, when given)."""
        name = self._unique_element_name(name, "particle")
        e = Particle(name, self.expr(mass, f"particle '{name}'.mass"),
                     self._vector(position, f"particle '{name}'.position", frame))
        self._elements.append(e)
        return e

    # ------------------------------------------------------------------- frames
    def add_frame(self, name: str, *, parent: str = WORLD, origin=(0, 0, 0), rotation=None) -> Frame:
        """A reference frame, chained from the inertial frame ``world``.

        Parameters
        ----------
        name : str
        parent : str
            ``"world"`` (default) or a frame added before.
        origin : 3 expressions
            The frame's origin in the parent's axes (relative to the parent's origin), of q and t.
        rotation : list of (axis, angle), or a 3x3 matrix, optional
            Successive elementary rotations about the frame's own current axes (intrinsic): axis
            ``"x"``, ``"y"``, ``"z"`` or a 3-vector, angle an expression of q and t
            (``[("z", "phi"), ("x", "theta"), ("z", "psi")]``, Euler's angles); or the rotation
            matrix itself (the frame's axes in the parent's, R with R^T R = I and det R = 1).
            Default: the parent's axes.

        Returns
        -------
        Frame
        """
        self._check_mutable()
        where = f"frame '{name}'"
        if not isinstance(name, str) or not name.isidentifier():
            raise ModelError(f"{where}: a frame's name must be an identifier (letters, digits, _), e.g. 'body'")
        if name == WORLD or name in self._frames:
            raise ModelError(f"{where}: the name is taken "
                             f"({'the inertial frame' if name == WORLD else 'another frame'}); "
                             "give each frame its own name")
        parent = self._frame_name(parent, f"{where}.parent")
        local = self._vector(origin, f"{where}.origin")
        if len(local) != 3:
            raise ModelError(f"{where}.origin: expected 3 components (x, y, z), got {len(local)}")
        frame = Frame(name, parent, local, self._factors(rotation, f"{where}.rotation"))
        self._frames[name] = frame
        return frame

    def _frame_name(self, name, where: str) -> str:
        if name == WORLD or name in self._frames:
            return name
        extra = did_you_mean(name, [WORLD, *self._frames])
        raise ModelError(f"{where}: no frame is named '{name}'{extra}; the frames are "
                         f"{', '.join([WORLD, *self._frames])} (add a frame with m.add_frame(...), or a "
                         "[[frames]] table, before what is placed in it)")

    def _factors(self, rotation, where: str) -> tuple[Factor, ...]:
        if rotation is None:
            return ()
        if isinstance(rotation, (sympy.Matrix, sympy.ImmutableMatrix)):
            rotation = rotation.tolist()
        if (isinstance(rotation, (list, tuple)) and len(rotation) == 3
                and all(isinstance(r, (list, tuple)) and len(r) == 3 for r in rotation)
                and not any(isinstance(r[0], str) for r in rotation)):
            rows = tuple(tuple(self.expr(x, f"{where}[{i}][{j}]") for j, x in enumerate(r))
                         for i, r in enumerate(rotation))
            return (Factor(matrix=rows),)
        if not isinstance(rotation, (list, tuple)):
            raise ModelError(f"{where}: expected a list of (axis, angle) pairs, e.g. [(\"z\", \"phi\"), "
                             f"(\"x\", \"theta\")], or a 3x3 rotation matrix, got {rotation!r}")
        out = []
        for k, step in enumerate(rotation):
            if not isinstance(step, (list, tuple)) or len(step) != 2:
                raise ModelError(f"{where}[{k}]: expected (axis, angle), e.g. (\"z\", \"phi\"), got {step!r}")
            axis, angle = step
            out.append(Factor(axis=self._axis(axis, f"{where}[{k}].axis"),
                              angle=self.expr(angle, f"{where}[{k}].angle")))
        return tuple(out)

    def _axis(self, axis, where: str) -> tuple:
        if isinstance(axis, str):
            if axis not in AXES:
                raise ModelError(f"{where}: '{axis}' is not an axis; use \"x\", \"y\", \"z\" or a 3-vector "
                                 "such as [1, 1, 0]")
            return tuple(sympy.Integer(a) for a in AXES[axis])
        if not isinstance(axis, (list, tuple)) or len(axis) != 3:
            raise ModelError(f"{where}: expected \"x\", \"y\", \"z\" or a 3-vector of numbers, got {axis!r}")
        v = [self.expr(a, f"{where}[{i}]") for i, a in enumerate(axis)]
        if not all(c.is_number for c in v):
            raise ModelError(f"{where}: an axis is fixed in the frame: its components must be numbers, got {axis!r}")
        norm = sympy.sqrt(sum(c ** 2 for c in v))
        if norm == 0:
            raise ModelError(f"{where}: the zero vector is not an axis; give its direction, e.g. [0, 0, 1]")
        return tuple(sympy.nsimplify(c / norm) for c in v)

    def add_joint(self, name: str, type: str, *, parent: str = WORLD, child: str | None = None, origin=(0, 0, 0),
                  rotation=None, axis=None, coordinates=None, limits=None, damping=None, friction=None,
                  sequence: str | None = None, limit_stiffness=None, parametrization: str | None = None,
                  omega=None):
        """A joint from the frame `parent` to a new frame `child` (default: the joint's name), with its
        coordinates (declared here unless declared before) and its dampers and friction.

        Parameters
        ----------
        name : str
        type : str
            ``"revolute"``, ``"prismatic"``, ``"cylindrical"``, ``"universal"``, ``"spherical"``,
            ``"planar"``, ``"fixed"`` or ``"floating"``.
        parent : str
            ``"world"`` or a frame added before (another joint's child).
        child : str, optional
            The name of the frame the joint creates; bodies are placed in it.
        origin, rotation :
            The joint frame's origin in the parent's axes and its constant rotation (as for
            :meth:`add_frame`); the motion is given in the joint frame's axes.
        axis : "x", "y", "z" or a 3-vector; two of them for a universal joint
            Default ``"z"`` (universal: ``("x", "y")``; a planar joint's axis is its plane's normal).
        coordinates : str or list of str, optional
            The joint's coordinate names (defaults: see :mod:`lagrangian.model._joints`).
        limits : (lower, upper), or one pair (or None) per coordinate
            Recorded on the joint; enforced only with `limit_stiffness`.
        limit_stiffness : expression, optional
            Enforce the limits by one-sided springs of this stiffness (end stops).
        damping, friction : expression, or one per coordinate
            Viscous damping (D = c q_dot^2 / 2; a spherical joint: D = c |omega|^2 / 2) and Coulomb
            friction (Q = -F sign(q_dot)), constants.
        sequence : str, optional
            The angle sequence of a spherical or floating joint (default ``"xyz"``, singular where the
            middle angle is +-pi/2).
        parametrization : str, optional
            A spherical or floating joint's rotation: ``"angles"`` (default: the three angles of
            `sequence`) or ``"quaternion"`` (four Euler parameters ``<name>_q0`` .. ``<name>_q3`` with the
            unit-norm constraint ``<name>_norm``: no singular posture; see :mod:`lagrangian.model._joints`).
        omega : 3 numbers, optional
            A quaternion joint's initial angular velocity [wx, wy, wz] (rad/s): the child's relative to
            the joint frame, in the child's own axes (body axes); the initial rates are
            q_dot = q (x) (0, omega) / 2 (:func:`lagrangian.quaternion_rates`) unless rates are given.

        Returns
        -------
        Joint
        """
        from ._joints import add_joint

        return add_joint(self, name, type, parent=parent, child=child, origin=origin, rotation=rotation, axis=axis,
                         coordinates=coordinates, limits=limits, damping=damping, friction=friction,
                         sequence=sequence, limit_stiffness=limit_stiffness, parametrization=parametrization,
                         omega=omega)

    # ------------------------------------------------------------------- bodies
    def add_rigid_body(self, mass, inertia, position=None, angle=None, *, frame: str | None = None,
                       center=(0, 0, 0), center_frame: str | None = None, shape: str | None = None,
                       radius=None, axis: str | None = None, inertia_about=None,
                       name: str | None = None) -> RigidBody | RigidBody3D:
        """A rigid body: planar, or in space when a `frame` gives its orientation.

        Planar: `mass`, centroidal `inertia` (a number), centre `position` and rotation `angle`.

        In space (`frame` given): `mass`; centroidal `inertia` in the frame's axes: three principal
        values (I1, I2, I3), the six components (xx, yy, zz, xy, yz, zx) of the tensor, or a 3x3
        matrix; the centre of mass `center` in the axes and from the origin of `center_frame`
        (default: the body's frame; ``"world"`` for world coordinates). The body's orientation is
        the frame's: its angular velocity is derived from the frame's rotations. Animations draw its
        frame's axes; ``shape="disk"`` with a `radius` (parameters and numbers) adds the circle
        across its body `axis` (``"x"``, ``"y"`` or ``"z"``, default ``"z"``), centred on its centre
        of mass. The shape is drawn only: the equations ignore it.

        `inertia_about`: the point the given inertia is about, when it is not the centre of mass (a
        vehicle's inertia about its axle, a link's about its joint): a point's name, or a position
        (planar: world coordinates (x, y); in space: (x, y, z) in the body frame's axes, from its
        origin). The point must be fixed on the body. The library applies the parallel-axis theorem,
        I_G = I_P - m (|r|^2 E - r r^T) with r = G - P in body axes (planar: I_G = I_P - m |r|^2), and
        the body holds its central inertia.
        """
        name = self._unique_element_name(name, "body")
        where = f"body '{name}'"
        if frame is None:
            if (shape, radius, axis) != (None, None, None):
                raise ModelError(f"{where}: shape, radius and axis draw a body in space (one with frame=...); a "
                                 "planar body is drawn as a disk of its radius of gyration")
            if position is None or angle is None:
                raise ModelError(f"{where}: a planar body needs a position and an angle; a body in space needs "
                                 "frame=... (the frame that carries it), with its center and its 3D inertia")
            e = RigidBody(name, self.expr(mass, f"{where}.mass"), self.expr(inertia, f"{where}.inertia"),
                          self._vector(position, f"{where}.position"), self.expr(angle, f"{where}.angle"))
            if inertia_about is not None:
                e = RigidBody(name, e.mass, self._central_inertia(e, inertia_about, where), e.position, e.angle)
        else:
            if position is not None or angle is not None:
                raise ModelError(f"{where}: a body in space takes its orientation from its frame and its centre "
                                 "from center=... (in the frame's axes): give no position or angle")
            frame = self._frame_name(frame, f"{where}.frame")
            at = self._vector(center, f"{where}.center", frame if center_frame is None else center_frame)
            e = RigidBody3D(name, self.expr(mass, f"{where}.mass"), self._inertia(inertia, f"{where}.inertia"),
                            at, frame, world_factors(self._frames, frame),
                            self._shape(shape, radius, axis, where))
            if inertia_about is not None:
                local = (tuple(self.expr(c, f"{where}.center[{i}]") for i, c in enumerate(center))
                         if center_frame in (None, frame) and not isinstance(center, str) else None)
                e = RigidBody3D(name, e.mass, self._central_inertia(e, inertia_about, where, local), e.position,
                                e.frame, e.factors, e.shape)
            from ._joints import scale_unit_quaternion

            scale_unit_quaternion(self, e)  # a quaternion joint's augmented inertia from its bodies
        self._elements.append(e)
        return e

    def _central_inertia(self, body, about, where: str, center_local=None):
        """The central inertia of `body` whose given inertia is about the point `about` (parallel axes)."""
        where = f"{where}.inertia_about"
        m = body.mass
        if isinstance(body, RigidBody):
            P = self._vector(about, where)
            if len(P) != len(body.position):
                raise ModelError(f"{where}: the point has {len(P)} components but the body's position has "
                                 f"{len(body.position)}; a planar body's inertia is about a point (x, y) of the plane")
            r2 = self._fixed_on_body([sum(((g - p) ** 2 for g, p in zip(body.position, P)), sympy.Integer(0))],
                                     where, "its distance from the centre of mass")[0]
            return body.inertia - m * r2
        if isinstance(about, str) and about in self._points():
            if center_local is not None:
                center_local = None  # the point is in world coordinates: r from both positions
        else:
            about = self._vector(about, where)
            if len(about) != 3:
                raise ModelError(f"{where}: expected a point's name or 3 components (x, y, z) in the body frame's "
                                 f"axes, got {len(about)}")
        if center_local is not None:  # both in the body's axes: r = c - p
            r = [c - p for c, p in zip(center_local, about)]
        else:
            P = self._points()[about] if isinstance(about, str) else self._vector(about, where, body.frame)
            if len(P) != 3:
                raise ModelError(f"{where}: '{about}' has a planar position; a body in space needs a point in space")
            _, R = frame_pose(self._frames, body.frame)
            r = self._fixed_on_body(list(R.T * (sympy.Matrix(body.position) - sympy.Matrix(P))), where,
                                    "its position relative to the centre of mass, in body axes")
        r2 = sum((x * x for x in r), sympy.Integer(0))
        return tuple(tuple(body.inertia[i][j] - m * ((r2 if i == j else 0) - r[i] * r[j]) for j in range(3))
                     for i in range(3))

    def _fixed_on_body(self, exprs, where: str, what: str) -> list:
        """`exprs` (of q, t and parameters) at q = 0, t = 0, after checking at random points that they do not
        depend on q and t (the point is fixed on the body); else a ModelError."""
        import numpy as np

        moving = set(self._coordinates) | {t}
        base = [sympy.sympify(e).subs({s: 0 for s in moving}) for e in exprs]
        free = sorted(set().union(*(sympy.sympify(e).free_symbols for e in exprs)), key=str)
        if free and moving & set(free):
            f = sympy.lambdify(free, [e - b for e, b in zip(exprs, base)], modules="numpy")
            g = sympy.lambdify(free, list(exprs), modules="numpy")
            rng = np.random.default_rng(22)
            for _ in range(4):
                point = rng.uniform(-2, 2, len(free))
                scale = 1 + float(np.max(np.abs(np.asarray(g(*point), dtype=float))))
                if float(np.max(np.abs(np.asarray(f(*point), dtype=float)))) > 1e-9 * scale:
                    raise ModelError(f"{where}: the point is not fixed on the body ({what} changes with the "
                                     "coordinates): give the inertia about a point that moves with the body, such as "
                                     "its frame's origin [0, 0, 0] or a point placed in its frame")
        return base

    def _shape(self, shape, radius, axis, where: str) -> Shape | None:
        r = None if radius is None else self.expr(radius, f"{where}.radius")
        variables = set(self.names(accelerations=True).values()) - set(self._parameters)
        problems = shape_problems(shape, r, axis, variables)
        if problems:
            raise ModelError([Problem(f"{where}.{field}: {message}") for field, message in problems])
        return None if shape is None else Shape(shape, r, axis or "z")

    def _inertia(self, value, where: str) -> tuple:
        """A 3x3 inertia tensor from 3 principal values, the 6 components or a 3x3 matrix."""
        if isinstance(value, (sympy.Matrix, sympy.ImmutableMatrix)):
            value = value.tolist()
        if isinstance(value, Mapping):
            keys = ("xx", "yy", "zz", "xy", "yz", "zx")
            unknown = set(value) - set(keys)
            if unknown or not {"xx", "yy", "zz"} <= set(value):
                raise ModelError(f"{where}: expected the components xx, yy, zz (and xy, yz, zx, default 0), "
                                 f"got {', '.join(map(str, value))}")
            value = [value.get(k, 0) for k in keys]
        if isinstance(value, (list, tuple)) and len(value) == 3 and all(
                isinstance(r, (list, tuple)) and len(r) == 3 for r in value):
            m = [[self.expr(x, f"{where}[{i}][{j}]") for j, x in enumerate(r)] for i, r in enumerate(value)]
            if any(sympy.simplify(m[i][j] - m[j][i]) != 0 for i in range(3) for j in range(i + 1, 3)):
                raise ModelError(f"{where}: an inertia tensor is symmetric; the matrix given is not")
            return tuple(tuple(r) for r in m)
        if isinstance(value, (list, tuple)) and len(value) in (3, 6):
            c = [self.expr(x, f"{where}[{i}]") for i, x in enumerate(value)]
            xx, yy, zz = c[:3]
            xy, yz, zx = c[3:] if len(c) == 6 else (sympy.Integer(0),) * 3
            return ((xx, xy, zx), (xy, yy, yz), (zx, yz, zz))
        raise ModelError(f"{where}: expected 3 principal moments (I1, I2, I3), the 6 components (xx, yy, zz, "
                         f"xy, yz, zx) or a 3x3 matrix, got {value!r}")

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

    def add_spring(self, stiffness, *, between=None, length=None, rest_length=0, acts: str = "both",
                   name: str | None = None) -> Spring:
        """A linear spring, V = k (length - rest_length)^2 / 2.

        Give `between` (two point names or positions) or `length` (any expression, e.g. a
        coordinate, or an angle for a torsional spring).

        `acts`: ``"both"`` (default); ``"compression"``, a one-sided spring that only pushes, when shorter
        than `rest_length` (a contact: two balls of radii r1, r2 with rest_length r1 + r2),
        V = k max(0, rest_length - length)^2 / 2; ``"tension"``, one that only pulls, when longer (a cable,
        a travel limit), V = k max(0, length - rest_length)^2 / 2.
        """
        name = self._unique_element_name(name, "spring")
        where = f"spring '{name}'"
        if acts not in SPRING_ACTS:
            raise ModelError([Problem(f"unknown value {acts!r}{did_you_mean(str(acts), SPRING_ACTS)}: a spring acts "
                                      "\"both\" ways (default), in \"compression\" only (it pushes when shorter than "
                                      "its rest length: a contact) or in \"tension\" only (it pulls when longer: a "
                                      "cable)", key=f"{where}.acts")])
        L, ends, names = self._length(between, length, where)
        e = Spring(name, self.expr(stiffness, f"{where}.stiffness"), L,
                   self.expr(rest_length, f"{where}.rest_length"), names, ends, acts)
        self._elements.append(e)
        return e

    def add_damper(self, coefficient, *, between=None, length=None, body: str | None = None,
                   name: str | None = None) -> Damper | RotationalDamper:
        """A linear viscous damper, D = c (d length/dt)^2 / 2 (`between` or `length` as for springs).

        With `body` (a rigid body's name) instead, a rotational damper on that body: the torque
        -c omega, D = c |omega|^2 / 2 with omega the body's angular velocity (in space: derived from
        its frame's rotations; planar: the rate of its angle)."""
        name = self._unique_element_name(name, "damper")
        where = f"damper '{name}'"
        if body is not None:
            if between is not None or length is not None:
                raise ModelError(f"{where}: give `body` (a rotational damper on a rigid body) or `between`/`length` "
                                 "(a damper along a length), not both")
            bodies = {e.name: e for e in self._elements if isinstance(e, (RigidBody, RigidBody3D))}
            if body not in bodies:
                raise ModelError(f"{where}.body: no rigid body is named '{body}'{did_you_mean(body, bodies)}; a "
                                 "rotational damper acts on a rigid body (add it first)")
            b = bodies[body]
            c = self.expr(coefficient, f"{where}.coefficient")
            e = (RotationalDamper(name, c, body, b.factors) if isinstance(b, RigidBody3D)
                 else Damper(name, c, b.angle))
            self._elements.append(e)
            return e
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

    def add_force(self, force, at, *, frame: str | None = None, name: str | None = None) -> Force:
        """A force vector applied at a point (its name or position); Q by virtual work. With
        `frame`, the force's components are in that frame's axes (a thrust along a body's axis)."""
        name = self._unique_element_name(name, "force")
        where = f"force '{name}'"
        F = self._vector(force, f"{where}.force")
        if frame is not None:
            if len(F) != 3:
                raise ModelError(f"{where}.force: a force in the frame '{frame}' has 3 components, got {len(F)}")
            _, R = frame_pose(self._frames, self._frame_name(frame, f"{where}.frame"))
            F = tuple(R * sympy.Matrix(F))
        r = self._vector(at, f"{where}.at")
        if len(F) != len(r):
            raise ModelError(f"{where}: the force has {len(F)} components but the point has {len(r)}; "
                             "give them the same dimension")
        e = Force(name, F, r, at if isinstance(at, str) else None)
        self._elements.append(e)
        return e

    def add_torque(self, torque, *, angle=None, body: str | None = None, frame: str | None = None,
                   name: str | None = None) -> Torque | Torque3D:
        """A torque acting on the rotation `angle` (an expression) or on the rigid body named `body`.

        On a body in space the torque is a 3-vector, its components in the axes of `frame` (default:
        the body's own frame; ``"world"`` for the inertial axes)."""
        name = self._unique_element_name(name, "torque")
        where = f"torque '{name}'"
        if (angle is None) == (body is None):
            raise ModelError(f"{where}: give either `angle` (an expression) or `body` (a rigid body's name), "
                             "exactly one of them")
        spatial = {e.name: e for e in self._elements if isinstance(e, RigidBody3D)}
        if body in spatial:
            tau = self._vector(torque, f"{where}.torque")
            if len(tau) != 3:
                raise ModelError(f"{where}.torque: a torque on the body '{body}' in space has 3 components "
                                 f"(x, y, z), got {len(tau)}")
            b = spatial[body]
            axes = b.frame if frame is None else self._frame_name(frame, f"{where}.frame")
            e = Torque3D(name, tau, body, axes, b.factors, world_factors(self._frames, axes))
            self._elements.append(e)
            return e
        if frame is not None:
            raise ModelError(f"{where}.frame: only a torque on a body in space has axes; a planar torque is a "
                             "number (about the axis normal to the plane)")
        if body is not None:
            bodies = {e.name: e for e in self._elements if isinstance(e, RigidBody)}
            if body not in bodies:
                raise ModelError(f"{where}.body: no rigid body is named '{body}'{did_you_mean(body, bodies)}")
            a = bodies[body].angle
        else:
            a = self.expr(angle, f"{where}.angle")
        e = Torque(name, self.expr(torque, f"{where}.torque"), a, body)
        self._elements.append(e)
        return e

    # -------------------------------------------------------------- constraints
    def add_constraint(self, expression, *, name: str | None = None) -> Constraint:
        """A holonomic constraint ``expression`` = 0, a function of the coordinates and t (a rod
        of length l: ``sqrt(x**2 + y**2) - l``). Its multiplier is ``lambda_<name>``, the
        generalized constraint force ``G^T lambda`` with G = d(expression)/dq."""
        return self._add_constraint(expression, name, HOLONOMIC)

    def add_velocity_constraint(self, expression, *, name: str | None = None) -> Constraint:
        """A velocity (nonholonomic) constraint ``expression`` = 0, linear in the velocities:
        a(q, t) . q_dot + b(q, t) (a knife edge: ``x_dot*sin(phi) - y_dot*cos(phi)``)."""
        return self._add_constraint(expression, name, VELOCITY)

    def add_wheel(self, frame: str, radius=None, *, axis: str = "y", center=(0, 0, 0), lateral: bool = True,
                  shape: str = "disk", semi_axes=None, name: str | None = None) -> Wheel:
        """A wheel rolling without slipping on the ground plane z = 0 (z up): a disk of `radius`
        carried by `frame`, its axle the frame's `axis` (``"x"``, ``"y"`` or ``"z"``) through `center`
        (in the frame's axes). Adds the contact condition (holonomic, ``<name>_contact``; left out when
        the coordinates keep the wheel on the ground) and the two no-slip conditions (velocity
        constraints ``<name>_x``, ``<name>_y``: the rim's point at the contact has no horizontal
        velocity), with the contact point computed from the frame's orientation. The multipliers
        are the contact forces on the wheel: normal (+z) and friction (x, y).

        ``lateral=False`` leaves out the lateral no-slip condition: the wheel keeps only the
        longitudinal one (``<name>_longitudinal``: no velocity of the contact point along the rolling
        direction a x n), so two wheels on one rigid axle (whose lateral conditions are one condition
        written twice) give independent constraints: give one of them ``lateral=False``.

        ``shape="ellipsoid"`` with ``semi_axes=(a, b, c)`` (along the frame's x, y, z; parameters and
        numbers) and no radius: a convex body rolling without slipping on the ground (the
        rattleback; a ball when a = b = c), its contact point the surface's lowest point from its
        support function (see :func:`~lagrangian.model._wheels.ellipsoid_conditions`), both no-slip
        conditions generated, the same constraint names."""
        self._check_mutable()
        if shape not in WHEEL_SHAPES:
            raise ModelError(f"wheel '{name}'.shape: unknown shape {shape!r}{did_you_mean(str(shape), WHEEL_SHAPES)}; "
                             "a \"disk\" (a wheel of radius r across its axle) or an \"ellipsoid\" (semi_axes = "
                             "[a, b, c] along its frame's axes) rolls on the ground")
        if shape == "ellipsoid":
            return self._add_ellipsoid(frame, radius, semi_axes, center, lateral, name)
        if semi_axes is not None:
            raise ModelError(f"wheel '{name}'.semi_axes: semi-axes belong to shape = \"ellipsoid\"; a disk has a "
                             "radius: give shape = \"ellipsoid\", or remove semi_axes")
        if radius is None:
            raise ModelError(f"wheel '{name}'.radius: a wheel (a disk) needs its radius, a number or an expression of "
                             "parameters such as \"r\"")
        if not isinstance(lateral, bool):
            raise ModelError(f"wheel '{name}'.lateral: expected true or false (whether the wheel cannot slide along "
                             f"its axle), got {lateral!r}")
        name, where, why = self._wheel_name(name)
        if why is not None:
            raise ModelError([Problem(why, key=where)])
        frame = self._frame_name(frame, f"{where}.frame")
        if frame == WORLD:
            raise ModelError(f"{where}.frame: a wheel is carried by a frame that moves with it, not the world; "
                             "add the wheel's frame (with its spin as its last rotation) and name it")
        if axis not in AXES:
            raise ModelError(f"{where}.axis: '{axis}' is not an axis of the frame; the axle is \"x\", \"y\" or \"z\"")
        r = self.expr(radius, f"{where}.radius")
        variables = set(self.names(accelerations=True).values()) - set(self._parameters)
        if r.free_symbols & variables:
            raise ModelError(f"{where}.radius: a wheel's radius is a number or an expression of parameters, "
                             f"got {r}")
        c = self._vector(center, f"{where}.center")
        if len(c) != 3:
            raise ModelError(f"{where}.center: expected 3 components (in the frame's axes), got {len(c)}")
        cond = rolling_conditions(self._frames, frame, r, axis, c, self._coordinates, t, self._wheel_values())
        return self._attach_wheel(Wheel(name, frame, r, axis, c, cond.contact is not None, lateral), cond, where)

    def _wheel_name(self, name) -> tuple[str, str, str | None]:
        """(the wheel's name, wheel 'name' for messages, what is wrong with the name or None): a
        name not given is wheel<k>, the first free one."""
        name, why = _named({w.name for w in self._wheels}, name, "wheel", "wheel")
        return name, f"wheel '{name}'", why

    def _wheel_values(self) -> dict:
        """The values a wheel's contact is found at: the parameters', the coordinates 0 or the model
        file's initial values (which branch of the contact condition is the one on the ground)."""
        values = {p: v for p, v in self._parameters.items() if v is not None}
        values.update({q: 0 for q in self._coordinates})
        values.update({self.symbol(k): v for k, v in (self.simulation.get("initial") or {}).items()
                       if k in {q.name for q in self._coordinates}})
        return values

    def _attach_wheel(self, wheel: Wheel, cond, where: str) -> Wheel:
        """The wheel's constraints (contact, then no-slip: both, or the longitudinal one alone) added
        under its constraint names, refused where one is taken; the wheel recorded."""
        for cname in wheel.constraint_names:
            if cname in {k.name for k in self._constraints}:
                raise ModelError([Problem(f"{where}: its constraint '{cname}' is already the name of a constraint; "
                                          "rename the wheel or the constraint", key=where)])
        if cond.contact is not None:
            self._add_constraint(cond.contact, f"{wheel.name}_contact", HOLONOMIC)
        if wheel.lateral:
            self._add_constraint(cond.no_slip_x, f"{wheel.name}_x", VELOCITY)
            self._add_constraint(cond.no_slip_y, f"{wheel.name}_y", VELOCITY)
        else:
            self._add_constraint(cond.longitudinal, f"{wheel.name}_longitudinal", VELOCITY)
        self._wheels.append(wheel)
        return wheel

    def _add_ellipsoid(self, frame, radius, semi_axes, center, lateral, name) -> Wheel:
        """add_wheel(shape="ellipsoid"): the contact and both no-slip conditions of an ellipsoid."""
        name, where, why = self._wheel_name(name)
        if why is None and radius is not None:
            why = (f"{where}.radius: an ellipsoid has semi_axes = [a, b, c], not a radius (a ball of radius r: "
                   "semi_axes = [r, r, r]); remove radius")
        if why is None and lateral is not True:
            why = f"{where}.lateral: an ellipsoid rolls without slipping in both directions; remove lateral"
        if why is not None:
            raise ModelError([Problem(why, key=where)])
        frame = self._frame_name(frame, f"{where}.frame")
        if frame == WORLD:
            raise ModelError(f"{where}.frame: a rolling body is carried by a frame that moves with it, not the world; "
                             "add its frame (rotations of the body) and name it")
        if not isinstance(semi_axes, (list, tuple)) or len(semi_axes) != 3:
            raise ModelError(f"{where}.semi_axes: an ellipsoid needs its 3 semi-axes [a, b, c] along its frame's x, "
                             f"y and z axes (numbers or expressions of parameters), got {semi_axes!r}")
        axes = tuple(self.expr(a, f"{where}.semi_axes[{i}]") for i, a in enumerate(semi_axes))
        variables = set(self.names(accelerations=True).values()) - set(self._parameters)
        values = self._wheel_values()
        for i, a in enumerate(axes):
            if a.free_symbols & variables:
                raise ModelError(f"{where}.semi_axes[{i}]: a semi-axis is a number or an expression of parameters, "
                                 f"got {a}")
            number = a.subs(values)
            if number.is_number and not (number.is_real and number > 0):
                raise ModelError(f"{where}.semi_axes[{i}]: a semi-axis is positive, got {number}")
        c = self._vector(center, f"{where}.center")
        if len(c) != 3:
            raise ModelError(f"{where}.center: expected 3 components (in the frame's axes), got {len(c)}")
        cond = ellipsoid_conditions(self._frames, frame, axes, c, self._coordinates, t, values)
        wheel = Wheel(name, frame, None, "z", c, cond.contact is not None, True, "ellipsoid", axes)
        return self._attach_wheel(wheel, cond, where)

    def _add_constraint(self, expression, name, kind) -> Constraint:
        self._check_mutable()
        name, why = _named({c.name for c in self._constraints}, name, "c", "constraint")
        if why is None and f"lambda_{name}" in self._all_names():
            why = (f"constraint '{name}': its multiplier 'lambda_{name}' is already the name of a coordinate, "
                   "parameter or input; rename one of them")
        if why is not None:
            raise ModelError([Problem(why, key=f"constraint '{name}'")])
        c = Constraint(name, self.expr(expression, f"constraint '{name}'"), kind)
        self._constraints.append(c)
        return c

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
            extra = did_you_mean(name, [c.name for c in self._coordinates])
            raise ModelError(f"forces.{name}: '{name}' is not a coordinate{extra}; "
                             "generalized forces are given by coordinate name")
        q = matches[0]
        self._Q[q] = self._Q.get(q, sympy.Integer(0)) + self.expr(expr, f"forces.{name}")

    # ------------------------------------------------------------------ outputs
    def add_output(self, name: str, expr) -> sympy.Expr:
        """A named output: an expression of the coordinates, velocities, inputs, parameters and t
        (a point's position, a spring's force, an angle relative to another), or ``"<point>.x"``
        (``.y``, ``.z``) for a component of a point's, particle's or body's position.

        Outputs are evaluated along a simulation (``traj["tip_x"]``, CSV columns after the others)
        and linearized (:attr:`LinearModel.output_matrix`, the rows C and D of y = C x + D u).
        Returns the expression."""
        self._check_mutable()
        why = check_name(name, "output")
        if why is None:
            taken = self._all_names() | {"energy", "jacobi_integral"}
            if name in taken:
                what = ("an output" if name in self._outputs else
                        "an energy column" if name in ("energy", "jacobi_integral") else
                        "a coordinate, parameter, input or multiplier")
                why = (f"output '{name}': the name is already {what}; a trajectory's columns need distinct "
                       "names, so rename the output")
        if why is not None:
            raise ModelError([Problem(why, key=f"outputs.{name}")])
        e = self._point_component(expr, f"outputs.{name}")
        if e is None:
            e = self.expr(expr, f"outputs.{name}")
        self._outputs[name] = e
        return e

    def _point_component(self, value, where: str) -> sympy.Expr | None:
        """The component of a point's position that ``"<point>.x"`` (``.y``, ``.z``) names, or None
        when `value` is not of that form."""
        if not isinstance(value, str):
            return None
        head, dot_, axis = value.strip().rpartition(".")
        if not dot_ or not head.isidentifier() or axis not in ("x", "y", "z"):
            return None
        points = self._points()
        if head not in points:
            raise ModelError([Problem(f"'{head}' is not a point, particle or body{did_you_mean(head, points)}: "
                                      f"\"<point>.{axis}\" is a component of a located element's position; "
                                      "use one of " + (", ".join(points) or "(none: add a point first)"),
                                      key=where)])
        position = points[head]
        k = "xyz".index(axis)
        if k >= len(position):
            raise ModelError([Problem(f"'{head}' has a planar position (x, y): it has no {axis} component; "
                                      f"use {head}.x or {head}.y", key=where)])
        return position[k]

    @property
    def outputs(self) -> dict[str, sympy.Expr]:
        """The named outputs, in the order they were added."""
        return dict(getattr(self, "_outputs", {}))

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
        sources += [(f"outputs.{name}", e, "output") for name, e in self.outputs.items()]
        for c in self._constraints:
            sources.append((f"constraint '{c.name}'", c.expression, c.kind))
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
        memo: dict = {}  # free symbols of the subexpressions the sources share (see _free_symbols)
        for where, e, role in sources:
            free = _free_symbols(e, memo)
            for s in sorted(free - known - qdd, key=str):
                extra = did_you_mean(s.name, [k.name for k in known], sentence=True)
                problems.append(Problem(
                    f"unknown symbol '{s.name}': it is not a coordinate, velocity, parameter, input or t.{extra} "
                    f"Declare it (m.parameter('{s.name}', value), or under [parameters] in a model file).",
                    key=where))
            for s in sorted(free & qdd, key=str):
                problems.append(Problem(f"acceleration '{s.name}' may not appear in a model: "
                                        "the equations produce accelerations, write energies and forces "
                                        "in terms of coordinates and velocities", key=where))
            if role in (HOLONOMIC, VELOCITY) and free & inputs:
                names = ", ".join(sorted(s.name for s in free & inputs))
                problems.append(Problem(f"input {names} appears in a constraint, whose time derivative the "
                                        "equations would need: write a prescribed motion as a function of t",
                                        key=where))
            if role == HOLONOMIC and free & qd:
                names = ", ".join(sorted(s.name for s in free & qd))
                problems.append(Problem(f"velocity {names} appears in a holonomic constraint g(q, t) = 0: write a "
                                        "constraint on the velocities as a velocity constraint "
                                        "(add_velocity_constraint, or velocity = \"...\" under [[constraints]])",
                                        key=where))
            if role == VELOCITY and not free & qd:
                problems.append(Problem("a velocity constraint has no velocity in it: write a constraint on the "
                                        "coordinates as a holonomic one (add_constraint, or holonomic = \"...\" "
                                        "under [[constraints]])", key=where))
            elif role == VELOCITY and _nonlinear_in(e, free & qd):
                problems.append(Problem("a velocity constraint must be linear in the velocities "
                                        "(a(q, t) . q_dot + b(q, t) = 0)", key=where))
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
                if e is None or isinstance(e, tuple):  # a body's inertia tensor in space: below
                    continue
                # a symbol or a number, as fields mostly are, without SymPy's (slow) subs
                val = sympy.sympify(values.get(e, e)) if e.is_Symbol else e if e.is_Number else e.subs(values)
                if val.is_number and val.is_real and float(val) < 0:
                    problems.append(Problem(f"{field_name} is negative ({float(val):g}): it must be zero or positive; "
                                            "check the sign or the parameter values",
                                            key=f"{el.kind} '{el.name}'.{field_name}"))
        for el in self._elements:
            if isinstance(el, RigidBody3D):
                problems += _inertia_problems(el, values)
                why = el.shape.value_problem(values) if el.shape is not None else None
                if why:
                    problems.append(Problem(why, key=f"{el.kind} '{el.name}'.radius"))
        for frame in self._frames.values():
            for f in frame.factors:
                if f.matrix is not None and f.rate is None:  # (a quaternion's is a rotation on its unit sphere)
                    problems += _rotation_problems(f.matrix, values, f"frame '{frame.name}'.rotation")
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
        self._derived = dict(getattr(self, "_derived", {}))
        self._inputs = list(self._inputs)
        self._elements = list(self._elements)
        self._frames = dict(self._frames)
        self._constraints = list(self._constraints)
        self._wheels = list(self._wheels)
        self._joints = dict(getattr(self, "_joints", {}))
        self._Q = dict(self._Q)
        self._outputs = dict(getattr(self, "_outputs", {}))
        self.simulation = copy.deepcopy(self.simulation)
        self.operating_point = dict(self.operating_point)
        self.optimal_control = dict(getattr(self, "optimal_control", {}))
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
        if getattr(self, "_derived", None):
            rows.insert(2, ("derived parameters", ", ".join(f"{html.escape(k)} = {tex(v)}"
                                                            for k, v in self._derived.items())))
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
        for name, value in self.outputs.items():
            rows.append((f"output {html.escape(name)}", tex(value)))
        body = "".join(f"<tr><th style='text-align:left'>{k}</th><td style='text-align:left'>{v}</td></tr>"
                       for k, v in rows)
        desc = f"<br><i>{html.escape(self.description)}</i>" if self.description else ""
        return f"<div><b>Model {html.escape(self.name)}</b>{desc}<table>{body}</table></div>"

    def __repr__(self) -> str:
        return (f"Model({self.name!r}, coordinates={[c.name for c in self._coordinates]}, "
                f"elements={len(self._elements)})")


def _is_number_text(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def derived_order(parameters: Mapping[str, object], where: str = "parameters") -> list[str]:
    """The names of `parameters` (name -> number, None, or an expression: a str or SymPy expression) in
    an order in which each derived parameter comes after those it uses (numbers first, in their order).
    A cycle is a ModelError that names it (``lA -> lB -> lA``)."""
    from ._expr import identifiers

    def uses(value) -> list[str]:
        if isinstance(value, str):
            try:
                return [n for n, _ in identifiers(value) if n in parameters]
            except ExpressionError:
                return []  # reported when it is parsed
        if isinstance(value, sympy.Basic):
            return sorted(s.name for s in value.free_symbols if s.name in parameters)
        return []

    derived = [n for n, v in parameters.items() if isinstance(v, (str, sympy.Basic))
               and not (isinstance(v, sympy.Basic) and v.is_Number or isinstance(v, str) and _is_number_text(v))]
    out = [n for n in parameters if n not in derived]
    state: dict[str, int] = {}  # 1: on the path, 2: placed

    def visit(name: str, path: list[str]) -> None:
        if state.get(name) == 2 or name not in derived:
            return
        if state.get(name) == 1:
            cycle = path[path.index(name):] + [name]
            if len(cycle) == 2:
                return  # a self-reference: parameter() says so
            raise ModelError([Problem(f"the parameters {' -> '.join(cycle)} are defined by each other in a cycle, so "
                                      f"none of them has a value: give one of them a number", key=f"{where}.{name}")])
        state[name] = 1
        for other in uses(parameters[name]):
            visit(other, path + [name])
        state[name] = 2
        out.append(name)

    for name in derived:
        visit(name, [])
    return out


def _free_symbols(expr, memo: dict) -> set:
    """`expr.free_symbols`, each shared subexpression visited once (`memo`: {id(node): (node, symbols)},
    read and filled): SymPy's walks the tree, which for the position of a body down a chain of frames
    (each entry of a product of rotations used by several of the next) costs many times its nodes."""
    if not isinstance(expr, sympy.Basic):
        return sympy.sympify(expr).free_symbols
    compound = (sympy.Add, sympy.Mul, sympy.Pow)
    stack = [(expr, False)]
    while stack:  # depth first, each node's symbols after its children's
        e, ready = stack.pop()
        if id(e) in memo:
            continue
        if type(e) not in compound:
            memo[id(e)] = (e, e.free_symbols)
        elif ready:
            memo[id(e)] = (e, set().union(*(memo[id(a)][1] for a in e.args)))
        else:
            stack.append((e, True))
            stack.extend((a, False) for a in e.args if id(a) not in memo)
    return set(memo[id(expr)][1])


def _nonlinear_in(expr, variables) -> bool:
    """Whether `expr` has a second derivative in `variables` (SymEngine: fast on large expressions)."""
    import symengine as se

    e = se.sympify(expr)
    variables = [se.Symbol(v.name) for v in variables]
    return any(e.diff(a).diff(b) != 0 for a in variables for b in variables)


def _numeric(expr, values) -> float | None:
    try:
        v = sympy.sympify(expr).subs(values)
        return float(v) if v.is_number and v.is_real else None
    except (TypeError, ValueError):
        return None


def _inertia_problems(body: RigidBody3D, values) -> list[Problem]:
    """A body's inertia tensor, when its entries have values: positive semi-definite (a zero
    moment is a slender rod about its axis) and its principal moments within the triangle
    inequality (I1 + I2 >= I3 and the like: no real body breaks it)."""
    import numpy as np

    where = f"{body.kind} '{body.name}'.inertia"
    numbers = [[_numeric(x, values) for x in row] for row in body.inertia]
    if any(x is None for row in numbers for x in row):
        return []
    moments = np.linalg.eigvalsh(np.array(numbers, dtype=float))
    scale = max(1e-300, float(np.abs(moments).max()))
    text = ", ".join(f"{m:g}" for m in moments)
    if moments.min() < -1e-12 * scale:
        return [Problem(f"the inertia tensor is not positive definite (principal moments {text}): a moment of "
                        "inertia is never negative; check the signs of the products of inertia (xy, yz, zx are "
                        "the tensor's entries) and the parameter values", key=where)]
    a, b, c = sorted(moments)
    if a + b < c - 1e-9 * scale:
        return [Problem(f"the principal moments of inertia {text} break the triangle inequality "
                        f"({a:g} + {b:g} < {c:g}): no body has them; a moment about an axis is at most the sum of "
                        "the other two (equal for a flat plate)", key=where)]
    return []


def _rotation_problems(matrix, values, where: str) -> list[Problem]:
    """A rotation matrix: R^T R = I and det R = 1, checked at random values of what it depends on."""
    import numpy as np

    M = sympy.Matrix(matrix).subs(values)
    free = sorted(M.free_symbols, key=str)
    f = sympy.lambdify(free, M, modules="numpy")
    rng = np.random.default_rng(3)
    for _ in range(5):
        try:
            R = np.array(f(*rng.uniform(-2, 2, len(free))), dtype=float)
        except (TypeError, ValueError, ZeroDivisionError):
            return [Problem("the rotation matrix could not be evaluated: its entries must be expressions of the "
                            "coordinates, parameters and t", key=where)]
        if not (np.allclose(R.T @ R, np.eye(3), atol=1e-9) and abs(np.linalg.det(R) - 1) < 1e-9):
            det = np.linalg.det(R)
            why = "its columns are not orthonormal (R^T R is not the identity)" if not np.allclose(
                R.T @ R, np.eye(3), atol=1e-9) else f"its determinant is {det:.3g}, not 1 (a reflection)"
            return [Problem(f"the matrix is not a rotation: {why}; check its entries, or write the rotation as "
                            "successive rotations about axes (rotation = [[\"z\", \"phi\"], [\"x\", \"theta\"]] in a "
                            "model file)", key=where)]
    return []


def _named(taken: set, name, prefix: str, kind: str):
    """(name, what is wrong with it or None): a name not given is <prefix><k>, the first free one
    counting from len(taken) + 1; a given one must be a valid name not taken."""
    if name is None:
        k = len(taken) + 1
        while f"{prefix}{k}" in taken:
            k += 1
        name = f"{prefix}{k}"
    why = check_name(name, kind)
    if why is None and name in taken:
        why = f"two {kind}s are named '{name}': give each {kind} its own name"
    return name, why
