"""Elements of a model: the parts T*, V, D and Q come from.

Each element is a frozen dataclass of SymPy expressions. Its contribution to the energies
and to the generalized forces is computed by :meth:`contribute`, in SymEngine, from a
:class:`~lagrangian.model._kinematics.Kinematics` that knows the coordinates and how to take
total time derivatives.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import sympy

from ._frames import AXES

if TYPE_CHECKING:  # pragma: no cover
    from ._kinematics import Kinematics

__all__ = [
    "Element", "Particle", "RigidBody", "RigidBody3D", "Shape", "SHAPES", "shape_problems", "Point", "Spring",
    "Damper", "Gravity", "Force", "Torque", "Torque3D", "Contribution", "RotationalDamper", "SPRING_ACTS",
]

Vector = tuple[sympy.Expr, ...]


@dataclass(frozen=True)
class Contribution:
    """What one element adds: kinetic co-energy T, potential V, dissipation D, forces Q (by coordinate)."""

    T: object = 0
    V: object = 0
    D: object = 0
    Q: tuple = ()


class Element:
    """Base class. Subclasses are frozen dataclasses with a `name`."""

    name: str
    kind: str = "element"

    def contribute(self, kin: "Kinematics") -> Contribution:  # pragma: no cover - abstract
        raise NotImplementedError

    def expressions(self) -> dict[str, sympy.Expr]:
        """Every expression of the element by field name, for checks (``position[1]`` etc.)."""
        out: dict[str, sympy.Expr] = {}
        for key, value in self.__dict__.items():
            if isinstance(value, tuple):
                for i, v in enumerate(value):
                    if isinstance(v, sympy.Basic):
                        out[f"{key}[{i}]"] = v
            elif isinstance(value, sympy.Basic):
                out[key] = value
        return out


@dataclass(frozen=True)
class Point(Element):
    """A massless point, named so that springs, dampers and loads can refer to it."""

    name: str
    position: Vector
    kind = "point"

    def contribute(self, kin):
        return Contribution()


@dataclass(frozen=True)
class Particle(Element):
    """A point mass at `position` (2 or 3 expressions of q and t): T* = m |v|^2 / 2."""

    name: str
    mass: sympy.Expr
    position: Vector
    kind = "particle"

    def contribute(self, kin):
        v = kin.velocity(self.position)
        return Contribution(T=kin.se(self.mass) * sum(vi * vi for vi in v) / 2)


@dataclass(frozen=True)
class RigidBody(Element):
    """A planar rigid body: mass, centroidal inertia, centre `position` and rotation `angle`.

    T* = m |v_G|^2 / 2 + I (d angle/dt)^2 / 2.
    """

    name: str
    mass: sympy.Expr
    inertia: sympy.Expr
    position: Vector
    angle: sympy.Expr
    kind = "rigid body"

    def contribute(self, kin):
        v = kin.velocity(self.position)
        w = kin.rate(self.angle)
        T = kin.se(self.mass) * sum(vi * vi for vi in v) / 2 + kin.se(self.inertia) * w * w / 2
        return Contribution(T=T)


@dataclass(frozen=True)
class Shape:
    """How a body in space is drawn besides its axes (animations only; the equations ignore it):
    a disk of `radius` (an expression of the parameters) centred on the body's centre of mass,
    in the plane orthogonal to the body `axis` ("x", "y" or "z", an axis of its frame)."""

    kind: str
    radius: sympy.Expr
    axis: str = "z"

    def value_problem(self, values) -> str | None:
        """What is wrong with the radius at the parameter `values` ({symbol: float}), if anything."""
        r = self.radius.subs(values)
        if r.is_number and r.is_real and not r > 0:
            return (f"the radius is {float(r):g}: a disk's radius must be positive; check the sign or the "
                    "parameter values")
        return None


#: The shapes a body in space may be drawn with, besides its axes.
SHAPES = ("disk",)


def shape_problems(shape, radius, axis, variables=frozenset()) -> list[tuple[str, str]]:
    """(field, message) for each problem of the drawn shape of a body in space.

    `shape` is None (no shape: axes only) or "disk"; `radius` the disk's radius (a SymPy
    expression, None when not given); `axis` None (default "z") or "x", "y", "z"; `variables` the
    symbols a radius may not use (coordinates, velocities, t, inputs: it is a constant).
    """
    out = []
    if shape is None:
        for field, value in (("radius", radius), ("axis", axis)):
            if value is not None:
                out.append((field, f"the {field} of a shape, but the body has none: give the shape \"disk\" with "
                                   "it, or leave it out"))
        return out
    if shape not in SHAPES:
        out.append(("shape", f"unknown shape {shape!r}: a body in space is drawn as a \"disk\" (a circle of a "
                             "given radius across one of its axes), or without a shape (its axes only)"))
    if radius is None:
        out.append(("radius", "a disk needs its radius: an expression of the parameters such as \"R\" (with a "
                              "value for R among the parameters), or a number"))
    elif radius.free_symbols & set(variables):
        names = ", ".join(sorted(s.name for s in radius.free_symbols & set(variables)))
        out.append(("radius", f"a disk's radius is a constant, but this one depends on {names}: write it with "
                              "parameters and numbers only"))
    elif radius.is_number and radius.is_real and not radius > 0:
        out.append(("radius", f"the radius is {float(radius):g}: a disk's radius must be positive"))
    if axis is not None and axis not in AXES:
        out.append(("axis", f"{axis!r} is not an axis of the body: a disk lies across the \"x\", \"y\" or \"z\" "
                            "axis of the body's frame"))
    return out


@dataclass(frozen=True)
class RigidBody3D(Element):
    """A rigid body in space: `mass`, centroidal `inertia` (3x3, in body axes), centre of mass
    `position` (world coordinates) and its orientation, the rotation from the world's axes to the
    body's as the `factors` of the chain of frames down to its `frame` (see ``_frames``); the
    `shape` it is drawn with, if any (:class:`Shape`).

    T* = m |v_G|^2 / 2 + omega^T I omega / 2, with omega the angular velocity in body axes, derived
    from the rotation (omega~ = R^T R').
    """

    name: str
    mass: sympy.Expr
    inertia: tuple  # 3 rows of 3
    position: Vector
    frame: str
    factors: tuple = ()
    shape: Shape | None = None
    kind = "rigid body"

    def expressions(self) -> dict[str, sympy.Expr]:
        out = {"mass": self.mass}
        if self.shape is not None:
            out["radius"] = self.shape.radius
        out.update({f"position[{i}]": v for i, v in enumerate(self.position)})
        out.update({f"inertia[{i}][{j}]": v for i, row in enumerate(self.inertia) for j, v in enumerate(row)})
        for k, f in enumerate(self.factors):
            if f.matrix is not None:
                out.update({f"rotation[{k}][{i}][{j}]": v for i, row in enumerate(f.matrix) for j, v in enumerate(row)})
            else:
                out[f"rotation[{k}]"] = f.angle
        return out

    def omega(self, kin) -> list:
        """The angular velocity in body axes (SymEngine)."""
        from ._frames import angular_velocity

        return angular_velocity(self.factors, kin)

    def contribute(self, kin):
        v = kin.velocity(self.position)
        w = self.omega(kin)
        inertia = [[kin.se(x) for x in row] for row in self.inertia]
        rotational = sum((w[i] * inertia[i][j] * w[j] for i in range(3) for j in range(3)), 0)
        return Contribution(T=kin.se(self.mass) * sum(vi * vi for vi in v) / 2 + rotational / 2)


#: How a spring acts: both ways, or one-sided (a contact, a cable).
SPRING_ACTS = ("both", "compression", "tension")


@dataclass(frozen=True)
class Spring(Element):
    """A linear spring: V = k (length - rest_length)^2 / 2.

    `length` is the distance between the two points of `between` (when given), or any scalar
    expression (a coordinate, or an angle for a torsional spring).

    `acts` = "compression": one-sided, it only pushes, when shorter than its rest length (a contact
    between two balls: rest length the sum of their radii): V = k max(0, rest_length - length)^2 / 2;
    "tension": it only pulls, when longer (a cable, a joint's limit): V = k max(0, length - rest_length)^2
    / 2. V is written as a Piecewise, so that its derivatives are exact on each side: the force is
    continuous (zero at the touch) and only the stiffness jumps there.
    """

    name: str
    stiffness: sympy.Expr
    length: sympy.Expr
    rest_length: sympy.Expr = sympy.Integer(0)
    between: tuple[str, str] | None = None
    ends: tuple[Vector, Vector] | None = field(default=None, repr=False)
    acts: str = "both"
    kind = "spring"

    def contribute(self, kin):
        import symengine as se

        k = kin.se(self.stiffness)
        if self.acts != "both":
            x = kin.se(self.length) - kin.se(self.rest_length)
            if self.acts == "compression":
                x = -x
            return Contribution(V=se.Piecewise((k * x * x / 2, se.Gt(x, 0)), (se.Integer(0), True)))
        if self.ends is not None and self.rest_length == 0:
            d = [kin.se(b) - kin.se(a) for a, b in zip(*self.ends)]
            return Contribution(V=k * sum(di * di for di in d) / 2)
        stretch = kin.se(self.length) - kin.se(self.rest_length)
        return Contribution(V=k * stretch * stretch / 2)


@dataclass(frozen=True)
class Damper(Element):
    """A linear viscous damper: D = c (d length/dt)^2 / 2, with `length` as for :class:`Spring`."""

    name: str
    coefficient: sympy.Expr
    length: sympy.Expr
    between: tuple[str, str] | None = None
    ends: tuple[Vector, Vector] | None = field(default=None, repr=False)
    kind = "damper"

    def contribute(self, kin):
        c = kin.se(self.coefficient)
        if self.ends is not None:
            d = [kin.se(b) - kin.se(a) for a, b in zip(*self.ends)]
            vd = [kin.rate(b) - kin.rate(a) for a, b in zip(*self.ends)]
            dist2 = sum(di * di for di in d)
            rate_times_length = sum(di * vi for di, vi in zip(d, vd))
            return Contribution(D=c * rate_times_length * rate_times_length / dist2 / 2)
        r = kin.rate(self.length)
        return Contribution(D=c * r * r / 2)


@dataclass(frozen=True)
class RotationalDamper(Element):
    """A rotational damper on a rigid body in space: the torque -s omega (omega its angular velocity),
    from the Rayleigh function D = s |omega|^2 / 2 (|omega| is the same in every axes; omega in body
    axes is derived from the body's rotations, as for its kinetic co-energy). `factors`: the world-to-
    body chain of the body's frame."""

    name: str
    coefficient: sympy.Expr
    body: str
    factors: tuple = ()
    kind = "rotational damper"

    def contribute(self, kin):
        from ._frames import angular_velocity

        w = angular_velocity(self.factors, kin)
        return Contribution(D=kin.se(self.coefficient) * sum(wi * wi for wi in w) / 2)


@dataclass(frozen=True)
class Gravity(Element):
    """Uniform gravity of magnitude `g` along `direction` (default: -y in 2D, -z in 3D).

    V = -sum m g direction . r over every particle and rigid body.
    """

    g: sympy.Expr
    direction: Vector | None = None
    name: str = "gravity"
    kind = "gravity"

    def contribute(self, kin):
        g = kin.se(self.g)
        if self.direction is not None:
            norm = sympy.sqrt(sum(c ** 2 for c in self.direction))
            unit = [kin.se(c / norm) for c in self.direction]
        V = 0
        for body in kin.massive_elements:
            r = body.position
            n = unit if self.direction is not None else [0] * (len(r) - 1) + [-1]
            V = V - kin.se(body.mass) * g * sum(ni * kin.se(ri) for ni, ri in zip(n, r))
        return Contribution(V=V)


@dataclass(frozen=True)
class Force(Element):
    """A force vector applied at a point: Q_k = F . d(position)/dq_k (virtual work)."""

    name: str
    force: Vector
    position: Vector
    at: str | None = None
    kind = "force"

    def contribute(self, kin):
        F = [kin.se(c) for c in self.force]
        r = [kin.se(c) for c in self.position]
        return Contribution(Q=tuple(sum(Fi * ri.diff(qk) for Fi, ri in zip(F, r)) for qk in kin.q))


@dataclass(frozen=True)
class Torque3D(Element):
    """A torque vector on a rigid body in space, its components in the axes of `frame` (the body's
    frame, another frame, or the world): Q_k = tau_body . d(omega_body)/d(q_dot_k) (virtual work:
    the torque times the virtual rotation)."""

    name: str
    torque: Vector
    body: str
    frame: str
    body_factors: tuple = ()
    frame_factors: tuple = ()
    kind = "torque"

    def contribute(self, kin):
        import symengine as se

        from ._frames import angular_velocity, rotation_product

        w = angular_velocity(self.body_factors, kin)
        # tau in body axes: R_body^T R_frame tau, the rotations common to both chains cancelled
        common = 0
        while (common < min(len(self.body_factors), len(self.frame_factors))
               and self.body_factors[common] == self.frame_factors[common]):
            common += 1
        to_body = (rotation_product(self.body_factors[common:]).T
                   * rotation_product(self.frame_factors[common:]))
        tau = to_body * sympy.Matrix(self.torque)
        tau = [kin.se(c) for c in tau]
        return Contribution(Q=tuple(sum((tau[i] * w[i].diff(v) for i in range(3)), se.Integer(0)) for v in kin.qd))


@dataclass(frozen=True)
class Torque(Element):
    """A torque acting on a rotation angle (of a body or any angle expression): Q_k = tau d(angle)/dq_k."""

    name: str
    torque: sympy.Expr
    angle: sympy.Expr
    body: str | None = None
    kind = "torque"

    def contribute(self, kin):
        tau = kin.se(self.torque)
        a = kin.se(self.angle)
        return Contribution(Q=tuple(tau * a.diff(qk) for qk in kin.q))
