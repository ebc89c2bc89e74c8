"""Rolling without slipping: a wheel (a disk of radius r) on the ground plane z = 0 (z up).

The wheel is carried by a frame; its axle is an axis ``a`` of that frame through the centre C.
With the ground's normal n = e_z, the point of the rim that touches the ground is

    P = C - r d,        d = (n - (n.a) a) / |n - (n.a) a| = (n - (n.a) a) / sqrt(1 - (n.a)^2),

the unit vector in the wheel's plane that points most upwards (its opposite points to the ground).
Two conditions follow (the user writes neither):

- contact (holonomic): the height of P is 0, ``C_z - r sqrt(1 - a_z^2) = 0``;
- no slip (two velocity constraints): the material point of the wheel at P has no horizontal
  velocity, ``(v_C + omega x (P - C))_x = 0`` and ``_y = 0``; its vertical velocity is the time
  derivative of the contact condition (the contact point slides along the rim), so it adds nothing.
  A wheel without its lateral condition (``lateral = false``: two wheels on one rigid axle, whose
  lateral conditions are the same condition twice) keeps only the longitudinal one, the velocity of
  P along the rolling direction a x n = (a_y, -a_x, 0): ``v_P,x a_y - v_P,y a_x = 0``
  (``<name>_longitudinal``; its multiplier times (a_y, -a_x, 0) is the friction force on the wheel).

With the wheel's rotation about its own axle written as the last rotations of its frame (a spin
angle), the geometry does not depend on that angle: the spin is taken out of R before P is formed
and its rate added back to omega along the axle, so the spin angle never appears in the constraints.

The multipliers are forces on the wheel at the contact: ``lambda_<name>_contact`` the normal force
(along +z), ``lambda_<name>_x``, ``lambda_<name>_y`` the friction force's components along the world's
axes. When the coordinates already keep the wheel on the ground (a rolling disk described by its
contact point and its lean: C_z = r cos(lean) identically), the contact condition is identically met and
is not added (squared, C_z^2 - r^2 (1 - a_z^2) simplifies to 0 and C_z > 0 at the model's state).
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy

from ._frames import AXES, Factor, chain, rotation_product

__all__ = ["Wheel", "RollingConditions", "rolling_conditions", "contact_is_identity", "ellipsoid_conditions",
           "WHEEL_SHAPES"]

#: The shapes that roll on the ground: a disk (a wheel) and an ellipsoid (a rattleback, a ball).
WHEEL_SHAPES = ("disk", "ellipsoid")


@dataclass(frozen=True)
class Wheel:
    """A wheel rolling without slipping on the ground z = 0: carried by `frame`, with its axle the
    frame's `axis` through `center` (in the frame's axes), of `radius`; its constraints are named
    ``<name>_contact`` (unless the coordinates keep it on the ground), ``<name>_x`` and ``<name>_y``."""

    name: str
    frame: str
    radius: sympy.Expr
    axis: str = "y"
    center: tuple = (0, 0, 0)
    contact: bool = True  # False: the coordinates keep the wheel on the ground
    lateral: bool = True  # False: only the longitudinal no-slip condition (the wheel may slide along its axle)
    shape: str = "disk"  # or "ellipsoid", of semi-axes `semi_axes` along the frame's x, y, z (radius None)
    semi_axes: tuple | None = None

    @property
    def constraint_names(self) -> tuple[str, ...]:
        slip = (f"{self.name}_x", f"{self.name}_y") if self.lateral else (f"{self.name}_longitudinal",)
        return ((f"{self.name}_contact",) if self.contact else ()) + slip


def _spinless(frames, frame: str, axis: tuple) -> tuple[list[Factor], list[sympy.Expr]]:
    """The world-to-frame factors with the trailing rotations about the axle taken out, and the
    angles of those (the spin)."""
    factors = [f for fr in chain(frames, frame) for f in fr.factors]
    spins = []
    while factors and factors[-1].matrix is None and tuple(sympy.sympify(a) for a in factors[-1].axis) == axis:
        spins.append(factors.pop().angle)
    return factors, spins


@dataclass(frozen=True)
class RollingConditions:
    """The conditions of a wheel (SymPy): `contact` (of q and t; None when the coordinates keep the
    wheel on the ground), `no_slip_x` and `no_slip_y` (linear in q_dot), and `longitudinal`, the
    contact point's velocity along the rolling direction a x n = (a_y, -a_x, 0) (a wheel without its
    lateral condition keeps only this one)."""

    contact: sympy.Expr | None
    no_slip_x: sympy.Expr
    no_slip_y: sympy.Expr
    longitudinal: sympy.Expr | None = None


def rolling_conditions(frames, frame: str, radius, axis: str, center, coordinates, time,
                       values) -> RollingConditions:
    """The contact and no-slip conditions of a wheel on the frame `frame` (see the module);
    `values` (parameters and a configuration) decide the sign where the contact is identically met."""
    from ._frames import angular_velocity, frame_pose
    from ._kinematics import Kinematics, to_sympy
    from ._symbols import dot

    def rate(expr):
        return sum((sympy.diff(expr, q) * dot(q) for q in coordinates), sympy.diff(expr, time))

    a_body = tuple(sympy.Integer(c) for c in AXES[axis])
    origin, R_full = frame_pose(frames, frame)
    factors, spins = _spinless(frames, frame, a_body)
    R = rotation_product(factors)  # the frame's axes without the spin (the axle is the same)
    C = sympy.Matrix(origin) + R_full * sympy.Matrix(center)
    a = R * sympy.Matrix(a_body)
    az = a[2]
    on_ground = contact_is_identity(C[2], az, radius, values)
    s = C[2] / radius if on_ground else sympy.sqrt(1 - az ** 2)  # |n x a|
    d = (sympy.Matrix([0, 0, 1]) - az * a) / s
    kin = Kinematics(coordinates)
    omega = R * sympy.Matrix([to_sympy(w) for w in angular_velocity(tuple(factors), kin)])
    for angle in spins:
        omega = omega + rate(angle) * a
    vP = sympy.Matrix([rate(c) for c in C]) + omega.cross(-radius * d)
    return RollingConditions(None if on_ground else C[2] - radius * s, vP[0], vP[1], vP[0] * a[1] - vP[1] * a[0])


def ellipsoid_conditions(frames, frame: str, semi_axes, center, coordinates, time, values) -> RollingConditions:
    """The contact and no-slip conditions of an ellipsoid rolling without slipping on the ground z = 0:
    semi-axes (a, b, c) along the x, y, z axes of `frame`, centred at `center` (in the frame's axes).

    The contact point is the surface's lowest point, from its support function: with n_b = R^T e_z the
    ground's normal in body axes and D = diag(a^2, b^2, c^2), the point of the surface whose outward
    normal is -n_b is p = -D n_b / sqrt(n_b^T D n_b) from the centre C (the gradient of the support
    function h(u) = sqrt(u^T D u) at u = -n_b), at the height C_z - sqrt(n_b^T D n_b). So the contact
    condition (holonomic) is C_z - sqrt(n_b^T D n_b) = 0 (left out when the coordinates keep the body on
    the ground), and no slip is (v_C + omega x R p)_x = 0 and _y = 0: the material point at the contact
    has no horizontal velocity (its vertical velocity is the contact condition's rate). A sphere
    (a = b = c = r) gives the rolling ball's conditions, v_C + omega x (-r e_z) = 0 horizontally."""
    from ._frames import angular_velocity, frame_pose
    from ._kinematics import Kinematics, to_sympy

    def rate(expr):
        from ._symbols import dot

        return sum((sympy.diff(expr, q) * dot(q) for q in coordinates), sympy.diff(expr, time))

    origin, R = frame_pose(frames, frame)
    C = sympy.Matrix(origin) + R * sympy.Matrix(center)
    n_b = R.T * sympy.Matrix([0, 0, 1])
    D = sympy.diag(*[a ** 2 for a in semi_axes])
    s = sympy.sqrt((n_b.T * D * n_b)[0])
    p_b = -D * n_b / s
    factors = tuple(f for fr in chain(frames, frame) for f in fr.factors)
    omega_b = sympy.Matrix([to_sympy(w) for w in angular_velocity(factors, Kinematics(coordinates))])
    vP = sympy.Matrix([rate(c) for c in C]) + R * omega_b.cross(p_b)
    on_ground = _identically_zero(C[2] ** 2 - s ** 2, values) and _positive(C[2], values)
    return RollingConditions(None if on_ground else C[2] - s, vP[0], vP[1])


def _identically_zero(expr, values) -> bool:
    """Whether `expr` vanishes at random points of its variables (the parameters near their values)."""
    import numpy as np
    import symengine as se

    symbols = sorted(expr.free_symbols, key=str)
    if not symbols:
        return expr == 0
    f = se.Lambdify([se.Symbol(x.name) for x in symbols], [se.sympify(expr)], real=True)
    rng = np.random.default_rng(7)
    base = np.array([float(values.get(x, 1.0)) for x in symbols])
    for _ in range(5):
        point = base * (1 + 0.3 * rng.standard_normal(len(symbols))) + 0.7 * rng.standard_normal(len(symbols))
        scale = float(np.max(np.abs(point))) ** 2 + 1.0
        if not abs(float(np.asarray(f(point)).ravel()[0])) <= 1e-12 * scale:
            return False
    return True


def _positive(expr, values) -> bool:
    try:
        return float(expr.subs(values)) > 0
    except (TypeError, ValueError):
        return False


def contact_is_identity(height, az, radius, values) -> bool:
    """Whether the coordinates keep the wheel on the ground: C_z^2 - r^2 (1 - a_z^2) vanishes
    identically (zero at random points of its variables, the parameters near their values: an
    expression of sines, cosines and polynomials that is not identically zero is not zero at random
    points but on a set of measure zero), and C_z > 0 at `values` (the model's numbers)."""
    import numpy as np
    import symengine as se

    squared = height ** 2 - radius ** 2 * (1 - az ** 2)
    symbols = sorted(squared.free_symbols | height.free_symbols, key=str)
    if symbols:
        f = se.Lambdify([se.Symbol(s.name) for s in symbols], [se.sympify(squared)], real=True)
        rng = np.random.default_rng(7)
        base = np.array([float(values.get(s, 1.0)) for s in symbols])
        for _ in range(5):
            point = base * (1 + 0.3 * rng.standard_normal(len(symbols))) + 0.7 * rng.standard_normal(len(symbols))
            scale = float(np.max(np.abs(point))) ** 2 + 1.0
            if not abs(float(np.asarray(f(point)).ravel()[0])) <= 1e-12 * scale:
                return False
    elif squared != 0:
        return False
    try:
        return float(height.subs(values)) > 0
    except (TypeError, ValueError):
        return False
