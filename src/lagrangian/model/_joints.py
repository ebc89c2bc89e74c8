"""Joints: the robotics vocabulary over frames.

A joint connects a `parent` frame (``"world"`` or any frame) to a new `child` frame. It is placed by
a constant *joint frame* J: its origin in the parent's axes and its constant rotation R0 (a list of
elementary rotations or a matrix, as for :meth:`Model.add_frame`). The joint's motion is then given
in J's axes, and the child frame is the single :class:`~lagrangian.model._frames.Frame`

    origin = o + R0 s(q),    rotation = R0 F1(q) F2(q) ...

with s the joint's translation and F_i its rotations (elementary rotations by coordinates). A joint
adds no mass: bodies are placed in the child frame (``add_rigid_body(..., frame=child)``).

=============  ===========  ============================================================================
type           coordinates  motion of the child frame in the joint frame's axes
=============  ===========  ============================================================================
revolute       1            rotation by q about `axis` (default ``"z"``)
prismatic      1            translation by q along `axis` (default ``"z"``)
cylindrical    2            rotation by q1 about `axis` and translation by q2 along it
universal      2            rotation by q1 about `axes[0]`, then by q2 about `axes[1]` of the rotated
                            frame (default ``("x", "y")``); the axes must not be parallel
spherical      3            three elementary rotations about the child's own current axes in the
                            `sequence` (default ``"xyz"``)
planar         3            translations q1, q2 in the plane normal to `axis` (default ``"z"``: x then
                            y; ``"x"``: y, z; ``"y"``: z, x) and rotation q3 about `axis`
fixed          0            none (a constant frame)
floating       6            translations along the joint frame's x, y, z, then three rotations in the
                            `sequence` (default ``"xyz"``): a free body
=============  ===========  ============================================================================

Spherical and floating joints use three angles by default, so that the coordinates stay
independent and the equations stay in the form M q'' = f without a norm constraint. Every choice
of three angles is singular somewhere; where is documented and chosen here: a Tait-Bryan sequence
(three different axes, the default ``"xyz"``) is singular where the middle angle is +-pi/2 (the first
and last axes align), a proper Euler sequence (``"zxz"``, ...) where the middle angle is 0 or pi.
The default ``"xyz"`` is regular at the joint's reference posture (all angles 0) and within +-pi/2 of
it in the middle angle; choose the joint frame's rotation so that the motion stays away from the
singular posture (Model.check and ``lagrangian check`` report a singular mass matrix there).

The singularity-free choice: ``parametrization = "quaternion"`` (Euler parameters). The rotation is
given by four coordinates q = (q0, q1, q2, q3) (q0 the scalar part) on the unit sphere |q| = 1, a
holonomic constraint ``<name>_norm``: q0^2 + q1^2 + q2^2 + q3^2 - 1 = 0 (its multiplier
``lambda_<name>_norm``), kept by the constrained solve and the projection after each step. The
rotation matrix is R(q) = (q0^2 - v.v) E + 2 v v^T + 2 q0 [v]x (v = (q1, q2, q3)), and the child's
angular velocity in its own axes is omega = 2 G(q) q_dot with

    G(q) = [[-q1,  q0,  q3, -q2],
            [-q2, -q3,  q0,  q1],
            [-q3,  q2, -q1,  q0]]

(Nikravesh's G; the same as the vector of R^T R' on the unit sphere, and linear in q_dot). Every
orientation, +-pi/2 of any angle included, is a regular point. Since omega does not see the
direction q_dot ~ q (G q = 0), T alone leaves M singular there, and the compiled solve factors M
(LDL^T) before it meets the constraint; so the joint adds the term T_n = k (q . q_dot)^2 / 2
(the "augmented inertia" of Nikravesh), which is zero with its gradient on the constraint
manifold (q . q_dot = 0 there): its Lagrange terms are k (q_dot . q_dot + q . q_ddot) q, along the
constraint's gradient and zero where the constraint's second derivative holds, so the motion and
the multiplier are unchanged, and M = 4 G^T I G + k q q^T (+ translations) is regular.

The value of k: on the unit sphere G G^T = E (3x3) and G q = 0, so the rows of G and q are an
orthonormal basis of R^4, and the 4x4 block 4 G^T I G + k q q^T has the eigenvalues 4 I_1, 4 I_2,
4 I_3 (I_i the principal inertias about the joint; eigenvectors G^T e_i) and k (eigenvector q).
For a sphere centred on the joint (I = I_s E) it is 4 I_s E_4, isotropic, exactly when k = 4 I_s:
so k = 4 x the mean principal inertia = 4/3 tr(I_G), summed over the rigid bodies whose nearest
quaternion joint above them (in the tree of frames) is this one, I_G each body's central inertia
(symbolic in the parameters where they are symbols; k = 1 while the joint carries no body). A
centre of mass at c from the joint adds 4 m |c|^2 along q (r = R(q) c is homogeneous of degree 2
in q) as it adds 4 m |c|^2 to two of the tangent eigenvalues, so the block's condition number is
that of the body's inertia about the joint (the units and the size of the body drop out: M of a
1e-6 kg m^2 link is as well conditioned as that of a 1e4 kg m^2 one); k = 1 in model units made
it 1e6 times worse for the small link.

Initial state, one rule (:func:`quaternion_start`, used by simulate, the constrained runs of the
CLI and the playground, and check): a joint whose components are not given starts at the identity
(1, 0, 0, 0), the joint frame's axes; where any component is given (by the caller, else by the
model file), the others not given are 0, and the quaternion is scaled to unit length (the nearest
point of the constraint); an all-zero (or non-finite) quaternion is an error naming the joint.
Initial rates: those given, else from the joint's initial angular velocity ``omega`` (the child's
angular velocity relative to the joint frame, in the child's own axes, body axes) as
q_dot = G(q)^T omega / 2 = q (x) (0, omega) / 2 (:func:`quaternion_rates`), else 0. Default
coordinate names ``<name>_q0`` .. ``<name>_q3`` (floating: ``<name>_x``, ``<name>_y``, ``<name>_z``
first).

Default coordinate names: revolute and prismatic ``<name>``; cylindrical ``<name>_angle``,
``<name>_slide``; universal ``<name>_1``, ``<name>_2``; spherical ``<name>_1`` .. ``<name>_3``; planar
``<name>_x``, ``<name>_y``, ``<name>_angle`` (the in-plane axes' letters); floating ``<name>_x``,
``<name>_y``, ``<name>_z``, ``<name>_1`` .. ``<name>_3``. A name already declared as a coordinate
is used as it is (so a model file may list them in ``coordinates``).

Dissipation: `damping` c adds a viscous damper on each coordinate, D = c q'^2 / 2 (a number or
expression for all, or one per coordinate); on a spherical joint it is the rotational damper
D = c |omega_rel|^2 / 2 (the torque -c omega_rel), omega_rel the child's angular velocity relative
to the joint frame. `friction` F adds Coulomb friction, the generalized force -F sign(q') on each
coordinate (discontinuous at q' = 0: an adaptive integrator takes small steps there).

Limits: ``limits = (lower, upper)`` per coordinate are recorded on the joint
(:attr:`Joint.limits`) and checked for lower < upper. With a `limit_stiffness` k they are enforced
by two one-sided springs on the coordinate (``add_spring(..., acts=...)``): V = k (q - upper)^2 / 2
beyond the upper limit, k (lower - q)^2 / 2 below the lower one, nothing in between (a stiff end
stop; the integrator takes small steps while it is touched). Without it, nothing pushes back.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from typing import TYPE_CHECKING

import sympy

from ..errors import ModelError, Problem
from ._elements import Contribution, Element
from ._frames import AXES, WORLD, Factor, Frame, rotation_product
from ._symbols import check_name, dot

if TYPE_CHECKING:  # pragma: no cover
    from ._model import Model

__all__ = ["Joint", "JOINT_TYPES", "PARAMETRIZATIONS", "RotationalDamper", "UnitQuaternion", "add_joint",
           "coordinate_count", "default_coordinates", "quaternion_matrix", "quaternion_rate", "quaternion_rates",
           "quaternion_start",
           "scale_unit_quaternion", "singular_angle"]

#: The joint types and their numbers of coordinates.
JOINT_TYPES = {"revolute": 1, "prismatic": 1, "cylindrical": 2, "universal": 2, "spherical": 3, "planar": 3,
               "fixed": 0, "floating": 6}

#: How a spherical or floating joint's rotation is given: three angles (default) or a unit quaternion.
PARAMETRIZATIONS = ("angles", "quaternion")

#: For a planar joint with the normal `axis`, its two in-plane axes (right-handed with the normal).
_PLANE = {"z": ("x", "y"), "x": ("y", "z"), "y": ("z", "x")}

Vector3 = tuple[sympy.Expr, sympy.Expr, sympy.Expr]


@dataclass(frozen=True)
class Joint:
    """A joint (see the module docstring).

    Attributes
    ----------
    name, type : str
    parent, child : str
        Frame names; the child frame is created by the joint.
    coordinates : tuple of sympy.Symbol
        The joint's coordinates, in the order of the table above.
    origin : tuple of 3 sympy.Expr
        The joint frame's origin in the parent's axes.
    factors : tuple of Factor
        The joint frame's constant rotation R0 relative to the parent.
    axes : tuple of 3-tuples
        The joint's axes in the joint frame's axes (revolute, prismatic, cylindrical: one; universal:
        two; planar: the normal; spherical, floating: the three rotation axes of the sequence).
    limits : tuple of (lower, upper) or None
        One per coordinate (recorded, not enforced).
    damping, friction : tuple of sympy.Expr or None
        One per coordinate (a spherical joint's damping: one rotational coefficient).
    sequence : str or None
        The angle sequence of a spherical or floating joint (None with a quaternion).
    parametrization : str
        ``"angles"`` or, for a spherical or floating joint, ``"quaternion"``.
    omega : tuple of 3 floats or None
        A quaternion joint's initial angular velocity: the child's relative to the joint frame, in the
        child's own axes (body axes), rad/s; the initial rates are q_dot = G(q)^T omega / 2 unless given.
    """

    name: str
    type: str
    parent: str
    child: str
    coordinates: tuple
    origin: Vector3
    factors: tuple = ()
    axes: tuple = ()
    limits: tuple = ()
    damping: tuple | None = None
    friction: tuple | None = None
    sequence: str | None = None
    limit_stiffness: sympy.Expr | None = None
    parametrization: str = "angles"
    omega: tuple | None = None

    @property
    def motion(self) -> tuple[Factor, ...]:
        """The joint's rotations by its coordinates (after the joint frame's R0)."""
        q = self.coordinates
        if self.parametrization == "quaternion":
            e = q[-4:]
            return (Factor(matrix=quaternion_matrix(e), rate=quaternion_rate(e)),)
        if self.type in ("revolute", "cylindrical"):
            return (Factor(axis=self.axes[0], angle=q[0]),)
        if self.type == "universal":
            return (Factor(axis=self.axes[0], angle=q[0]), Factor(axis=self.axes[1], angle=q[1]))
        if self.type == "planar":
            return (Factor(axis=self.axes[0], angle=q[2]),)
        if self.type == "spherical":
            return tuple(Factor(axis=a, angle=c) for a, c in zip(self.axes, q))
        if self.type == "floating":
            return tuple(Factor(axis=a, angle=c) for a, c in zip(self.axes, q[3:]))
        return ()

    @property
    def translation(self) -> Vector3:
        """s(q): the child's origin in the joint frame's axes."""
        q = self.coordinates
        zero = sympy.Integer(0)
        if self.type == "prismatic":
            return tuple(a * q[0] for a in self.axes[0])
        if self.type == "cylindrical":
            return tuple(a * q[1] for a in self.axes[0])
        if self.type == "planar":
            name = next(k for k, v in AXES.items() if tuple(sympy.Integer(c) for c in v) == self.axes[0])
            e1, e2 = (AXES[a] for a in _PLANE[name])
            return tuple(q[0] * a + q[1] * b for a, b in zip(e1, e2))
        if self.type == "floating":
            return (q[0], q[1], q[2])
        return (zero, zero, zero)

    def frame(self) -> Frame:
        """The child frame."""
        R0 = rotation_product(self.factors)
        s = R0 * sympy.Matrix(self.translation)
        origin = tuple(o + d for o, d in zip(self.origin, s))
        return Frame(self.child, self.parent, origin, tuple(self.factors) + self.motion)


def quaternion_matrix(e) -> tuple:
    """R(q) of the unit quaternion q = (q0, q1, q2, q3) (q0 the scalar part), as 3 rows: homogeneous of
    degree 2, a rotation on the unit sphere (|q|^2 times one elsewhere)."""
    q0, q1, q2, q3 = e
    return ((q0**2 + q1**2 - q2**2 - q3**2, 2 * (q1 * q2 - q0 * q3), 2 * (q1 * q3 + q0 * q2)),
            (2 * (q1 * q2 + q0 * q3), q0**2 - q1**2 + q2**2 - q3**2, 2 * (q2 * q3 - q0 * q1)),
            (2 * (q1 * q3 - q0 * q2), 2 * (q2 * q3 + q0 * q1), q0**2 - q1**2 - q2**2 + q3**2))


def quaternion_rate(e) -> tuple:
    """omega = 2 G(q) q_dot, the angular velocity in the rotated axes of the quaternion q (see the module
    docstring), as 3 expressions of q and q_dot."""
    q0, q1, q2, q3 = e
    d0, d1, d2, d3 = (dot(c) for c in e)
    return (2 * (-q1 * d0 + q0 * d1 + q3 * d2 - q2 * d3),
            2 * (-q2 * d0 - q3 * d1 + q0 * d2 + q1 * d3),
            2 * (-q3 * d0 + q2 * d1 - q1 * d2 + q0 * d3))


def _vector_of(value, n: int, what: str, example: str):
    """`value` as n finite floats, or ModelError naming `what` and an example."""
    import numpy as np

    if isinstance(value, (str, bytes)) or value is None:
        arr = None
    else:
        try:
            arr = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            arr = None
    if arr is None or arr.shape != (n,):
        shape = "" if arr is None else f" of shape {arr.shape}"
        raise ModelError([Problem(f"{what} has {n} numbers, e.g. {example}, got {str(value)[:80]!r}{shape}",
                                  key=what.split()[0])])
    if not np.all(np.isfinite(arr)):
        raise ModelError([Problem(f"{what} must be finite numbers, got {arr.tolist()}", key=what.split()[0])])
    return arr


def _number_text(value) -> str:
    try:
        return f"{float(value):.6g}"
    except (TypeError, ValueError):
        return repr(value)[:40]


def quaternion_start(model: "Model", model_values, caller_values=None) -> tuple[dict[str, float], list[str]]:
    """The initial components (and rates) of every quaternion joint of `model` by the one rule (see the module
    docstring): (values by coordinate and velocity name, which a start keeps as given; notes).

    Parameters
    ----------
    model : Model
    model_values : mapping of str to float
        The model's own initial values (``model.simulation["initial"]``).
    caller_values : mapping of str to float, optional
        The values the caller gave (simulate's `initial`, the CLI's --initial, the playground's sliders),
        which replace the model's for a joint where they name any of its components.

    Raises
    ------
    ModelError
        A quaternion that is zero or not finite, naming the joint, its values and the fix.
    """
    import numpy as np

    out: dict[str, float] = {}
    notes: list[str] = []
    problems: list[Problem] = []
    model_values = {getattr(k, "name", k): v for k, v in (model_values or {}).items()}
    caller_values = {getattr(k, "name", k): v for k, v in (caller_values or {}).items()}
    for j in getattr(model, "_joints", {}).values():
        if j.parametrization != "quaternion":
            continue
        names = [c.name for c in j.coordinates[-4:]]
        rates = [f"{c}_dot" for c in names]
        source = next((v for v in (caller_values, model_values) if any(c in v for c in names)), None)
        if source is None:
            q = np.array([1.0, 0.0, 0.0, 0.0])
        else:
            try:
                q = np.array([float(source.get(c, 0.0)) for c in names])
            except (TypeError, ValueError):
                q = np.full(4, np.nan)
            norm = float(np.linalg.norm(q)) if np.all(np.isfinite(q)) else math.nan
            given = ", ".join(f"{c} = {_number_text(source[c])}" for c in names if c in source)
            if not norm > 0 or not math.isfinite(norm):
                what = "zero, which is no rotation" if norm == 0 else "not finite"
                problems.append(Problem(
                    f"the initial quaternion of joint '{j.name}' ({given}; the components not given are 0) is "
                    f"{what}: give a unit quaternion, e.g. {names[0]} = 1 for the joint frame's axes, or "
                    f"{names[0]} = 0, {names[3]} = 1 for a half turn about z (leave all four out for the identity)",
                    key="initial"))
                continue
            if abs(norm - 1.0) > 1e-12:
                notes.append(f"The initial quaternion of joint '{j.name}' ({given}; the components not given are "
                             f"0) has length {norm:.6g}: it was scaled to unit length, "
                             f"({', '.join(f'{v:.6g}' for v in q / norm)}).")
                q = q / norm
        out.update(zip(names, (float(v) for v in q)))
        if j.omega is not None and not any(r in v for v in (caller_values, model_values) for r in rates):
            out.update(zip(rates, (float(v) for v in quaternion_rates(q, j.omega))))
    if problems:
        raise ModelError(problems)
    return out, notes


def quaternion_rates(q, omega):
    """The quaternion rates q_dot of the angular velocity `omega`: q_dot = q (x) (0, omega) / 2 = G(q)^T omega / 2.

    Parameters
    ----------
    q : array_like, shape (4,)
        A unit quaternion (q0, q1, q2, q3), q0 the scalar part: a quaternion joint's ``<name>_q0`` ..
        ``<name>_q3``.
    omega : array_like, shape (3,)
        The angular velocity in the rotated (child, body) axes: for a joint, the child frame's angular
        velocity relative to the joint frame, in the child's own axes (rad/s).

    Returns
    -------
    numpy.ndarray, shape (4,)
        q_dot, tangent to the unit sphere (q . q_dot = 0); omega = 2 G(q) q_dot gives omega back.

    Raises
    ------
    ModelError
        q or omega of the wrong length, not numbers, or not finite.

    Examples
    --------
    >>> lg.quaternion_rates([1, 0, 0, 0], [0, 0, 2.0])  # turning at 2 rad/s about z
    array([0., 0., 0., 1.])
    """
    import numpy as np

    q0, q1, q2, q3 = _vector_of(q, 4, "q (a quaternion)", "[1, 0, 0, 0]")
    w = _vector_of(omega, 3, "omega (an angular velocity)", "[0, 0, 1.5]")
    G = np.array([[-q1, q0, q3, -q2], [-q2, -q3, q0, q1], [-q3, q2, -q1, q0]])
    return G.T @ w / 2


@dataclass(frozen=True)
class UnitQuaternion(Element):
    """The augmented inertia of a quaternion joint's coordinates: T = k (q . q_dot)^2 / 2, zero with its
    gradient on the unit sphere, so that M is regular and the motion unchanged (see the module docstring).

    k = 4/3 sum tr(I_b) over the rigid bodies `bodies` whose nearest quaternion joint above them is this one
    (:func:`scale_unit_quaternion`), I_b a body's central inertia: 4 times their mean principal inertia,
    symbolic where the inertias are; 1 (model units) while no body is there."""

    name: str
    coordinates: tuple = ()
    coefficient: sympy.Expr = sympy.Integer(1)
    bodies: tuple = ()
    kind = "unit quaternion"

    def expressions(self) -> dict[str, sympy.Expr]:
        return {"coefficient": self.coefficient}

    def contribute(self, kin):
        s = sum((kin.se(c) * kin.se(dot(c)) for c in self.coordinates), kin.se(sympy.Integer(0)))
        return Contribution(T=kin.se(self.coefficient) * s * s / 2)


def scale_unit_quaternion(model: "Model", body) -> None:
    """Add the rigid body `body` (in space, about to be added to `model`) to the augmented inertia of the
    nearest quaternion joint above its frame, if any: k = 4/3 sum tr(I_b) of its bodies' central inertias
    (see the module docstring). A body fixed in the world, or below no quaternion joint, changes nothing."""
    from dataclasses import replace

    quaternions = {j.child: j for j in getattr(model, "_joints", {}).values() if j.parametrization == "quaternion"}
    if not quaternions:
        return
    frame = body.frame
    while frame in model._frames and frame not in quaternions:
        frame = model._frames[frame].parent
    joint = quaternions.get(frame)
    if joint is None:
        return
    e = tuple(joint.coordinates[-4:])
    for i, element in enumerate(model._elements):
        if isinstance(element, UnitQuaternion) and tuple(element.coordinates) == e:
            trace = sympy.Rational(4, 3) * sum((body.inertia[k][k] for k in range(3)), sympy.Integer(0))
            k = trace if not element.bodies else element.coefficient + trace
            model._elements[i] = replace(element, coefficient=k, bodies=element.bodies + (body.name,))
            return


@dataclass(frozen=True)
class RotationalDamper(Element):
    """A rotational damper on the rotations `factors` (a spherical joint's): D = c |omega|^2 / 2, omega
    their angular velocity in the last one's axes (the torque -c omega)."""

    name: str
    coefficient: sympy.Expr
    factors: tuple = ()
    kind = "damper"

    def expressions(self) -> dict[str, sympy.Expr]:
        return {"coefficient": self.coefficient}

    def contribute(self, kin):
        from ._frames import angular_velocity

        w = angular_velocity(self.factors, kin)
        return Contribution(D=kin.se(self.coefficient) * sum(wi * wi for wi in w) / 2)


def singular_angle(sequence: str) -> str:
    """Where a sequence of three angles is singular, in words."""
    if sequence[0] == sequence[2]:
        return "the middle angle is 0 or pi (proper Euler angles: the first and last axes align)"
    return "the middle angle is +-pi/2 (Tait-Bryan angles: the first and last axes align)"


def coordinate_count(type: str, parametrization: str | None = None) -> int:
    """The number of coordinates of a joint: JOINT_TYPES, one more for a quaternion."""
    return JOINT_TYPES[type] + (1 if parametrization == "quaternion" and type in ("spherical", "floating") else 0)


def default_coordinates(name: str, type: str, axis=None, sequence=None, parametrization=None) -> tuple[str, ...]:
    """The default coordinate names of a joint (see the module docstring)."""
    if parametrization == "quaternion" and type in ("spherical", "floating"):
        quaternion = tuple(f"{name}_q{i}" for i in range(4))
        return quaternion if type == "spherical" else (f"{name}_x", f"{name}_y", f"{name}_z") + quaternion
    if type in ("revolute", "prismatic"):
        return (name,)
    if type == "cylindrical":
        return (f"{name}_angle", f"{name}_slide")
    if type == "universal":
        return (f"{name}_1", f"{name}_2")
    if type == "spherical":
        return (f"{name}_1", f"{name}_2", f"{name}_3")
    if type == "planar":
        a, b = _PLANE.get(axis if isinstance(axis, str) else "z", ("x", "y"))
        return (f"{name}_{a}", f"{name}_{b}", f"{name}_angle")
    if type == "floating":
        return (f"{name}_x", f"{name}_y", f"{name}_z", f"{name}_1", f"{name}_2", f"{name}_3")
    return ()


def _types_text() -> str:
    return ", ".join(JOINT_TYPES)


def add_joint(model: "Model", name: str, type: str, *, parent: str = WORLD, child: str | None = None,
              origin=(0, 0, 0), rotation=None, axis=None, coordinates=None, limits=None, damping=None,
              friction=None, sequence: str | None = None, limit_stiffness=None,
              parametrization: str | None = None, omega=None) -> Joint:
    """Add a joint to `model` (:meth:`Model.add_joint` documents the arguments). All or nothing: on a
    problem, nothing is added and one ModelError lists every problem found."""
    from .._util import did_you_mean

    model._check_mutable()
    where = f"joint '{name}'"
    problems: list[Problem] = []

    def problem(key: str, message: str) -> None:
        problems.append(Problem(message, key=f"{where}.{key}" if key else where))

    if not isinstance(name, str) or not name.isidentifier():
        raise ModelError([Problem(f"a joint's name must be an identifier (letters, digits, _), e.g. 'shoulder', "
                                  f"got {name!r}", key="joint")])
    joints = getattr(model, "_joints", {})
    if name in joints:
        raise ModelError([Problem("two joints have this name: give each joint its own name", key=where)])
    if type not in JOINT_TYPES:
        extra = did_you_mean(str(type), JOINT_TYPES) if isinstance(type, str) else ""
        raise ModelError([Problem(f"unknown joint type {type!r}{extra}; the types are {_types_text()}",
                                  key=f"{where}.type")])
    quaternion = False
    if parametrization is not None:
        if type not in ("spherical", "floating"):
            problem("parametrization", f"only spherical and floating joints have a parametrization (\"angles\" or "
                                       f"\"quaternion\"); a {type} joint has none: remove it")
        elif parametrization not in PARAMETRIZATIONS:
            extra = did_you_mean(str(parametrization), PARAMETRIZATIONS) if isinstance(parametrization, str) else ""
            problem("parametrization", f"unknown parametrization {parametrization!r}{extra}; expected \"angles\" "
                                       "(three angles, the default) or \"quaternion\" (four Euler parameters with "
                                       "a unit-norm constraint: no singular posture)")
        else:
            quaternion = parametrization == "quaternion"
    n = coordinate_count(type, "quaternion" if quaternion else None)
    child = name if child is None else child
    if not isinstance(child, str) or not child.isidentifier():
        problem("child", f"the child frame's name must be an identifier, e.g. 'upper_arm', got {child!r}")
    elif child == WORLD or child in model._frames:
        problem("child", f"the frame '{child}' exists already ({'the inertial frame' if child == WORLD else 'a frame'}"
                         "): a joint creates its child frame, so give it a new name (child = \"...\")")
    try:
        parent = model._frame_name(parent, f"{where}.parent")
    except ModelError as exc:
        problems.extend(exc.problems)
        parent = None
    try:
        o = model._vector(origin, f"{where}.origin")
        if len(o) != 3:
            problem("origin", f"a joint's origin has 3 components (x, y, z), got {len(o)}")
    except ModelError as exc:
        problems.extend(exc.problems)
        o = None
    try:
        factors = model._factors(rotation, f"{where}.rotation")
    except ModelError as exc:
        problems.extend(exc.problems)
        factors = ()

    # axes
    axes: tuple = ()
    seq = None
    if type in ("spherical", "floating"):
        if axis is not None:
            problem("axis", f"a {type} joint turns about three axes given by its sequence (default \"xyz\"), not "
                            "one axis: remove axis, or give sequence = \"zyx\" (three of x, y, z)")
        seq = "xyz" if sequence is None else sequence
        if quaternion and sequence is not None:
            problem("sequence", f"a quaternion {type} joint has no sequence of angles: remove sequence, or give "
                                "parametrization = \"angles\"")
        if not (isinstance(seq, str) and len(seq) == 3 and set(seq) <= set("xyz")
                and seq[0] != seq[1] and seq[1] != seq[2]):
            problem("sequence", f"expected three axes among x, y, z, no two neighbours the same (\"xyz\", \"zyx\", "
                                f"\"zxz\"), got {sequence!r}")
            seq = "xyz"
        axes = tuple(tuple(sympy.Integer(c) for c in AXES[a]) for a in seq)
    else:
        if sequence is not None:
            problem("sequence", f"only spherical and floating joints have a sequence of angles; a {type} joint "
                                "has none: remove it")
        if type == "universal":
            pair = ("x", "y") if axis is None else axis
            if not isinstance(pair, (list, tuple)) or len(pair) != 2 or all(
                    isinstance(c, numbers.Number) for c in pair):
                problem("axis", f"a universal joint has two axes, e.g. [\"x\", \"y\"], got {axis!r}")
            else:
                try:
                    axes = tuple(model._axis(a, f"{where}.axis[{i}]") for i, a in enumerate(pair))
                    cross = sympy.Matrix(axes[0]).cross(sympy.Matrix(axes[1]))
                    if all(sympy.simplify(c) == 0 for c in cross):
                        problem("axis", "the two axes of a universal joint are parallel: give two different "
                                        "directions, e.g. [\"x\", \"y\"]")
                except ModelError as exc:
                    problems.extend(exc.problems)
        elif type == "planar":
            normal = "z" if axis is None else axis
            if not isinstance(normal, str) or normal not in _PLANE:
                problem("axis", f"a planar joint's axis is its plane's normal, \"x\", \"y\" or \"z\" of the joint "
                                f"frame (turn the joint frame with rotation = ... for another plane), got {axis!r}")
                normal = "z"
            axes = (tuple(sympy.Integer(c) for c in AXES[normal]),)
        elif type == "fixed":
            if axis is not None:
                problem("axis", "a fixed joint has no axis: remove it")
        else:
            try:
                axes = (model._axis("z" if axis is None else axis, f"{where}.axis"),)
            except ModelError as exc:
                problems.extend(exc.problems)

    # coordinates
    if quaternion:
        seq, axes = None, ()
    pz = "quaternion" if quaternion else None
    if coordinates is None:
        names = default_coordinates(name, type, axis, seq, pz)
    elif isinstance(coordinates, str):
        names = (coordinates,)
    else:
        names = tuple(coordinates) if isinstance(coordinates, (list, tuple)) else None
    if names is None or len(names) != n:
        example = list(default_coordinates(name, type, axis, seq, pz))
        problem("coordinates", f"a {type} joint has {n} coordinate{'s' if n != 1 else ''}, got {coordinates!r}"
                               + (f"; give {n} name{'s' if n != 1 else ''}, e.g. {example}" if n else "; remove it"))
        names = ()
    existing = {c.name: c for c in model._coordinates}
    used = {c.name: j.name for j in joints.values() for c in j.coordinates}
    new_names: list[str] = []
    for i, cname in enumerate(names):
        key = "coordinates" if coordinates is None else f"coordinates[{i}]"
        if isinstance(cname, sympy.Symbol):
            cname = cname.name
        if cname in used:
            problem(key, f"the coordinate '{cname}' is the joint '{used[cname]}''s already: each joint needs "
                         "coordinates of its own")
            continue
        if cname in existing:
            continue
        why = check_name(cname, "coordinate")
        if why is None and cname in model._all_names():
            why = f"'{cname}' is already a parameter, input or other name: a joint's coordinate needs a new name"
        if why is None and cname in new_names:
            why = f"'{cname}' is given twice"
        if why is not None:
            problem(key, why + (" (give the joint's coordinates with coordinates = [...])" if coordinates is None
                                else ""))
            continue
        new_names.append(cname)

    if quaternion and limits is not None:
        problem("limits", "a quaternion's components have no limits (they are not angles): remove limits, or give "
                          "parametrization = \"angles\" to record limits of three angles")
        limits = None
    limits_t = _per_coordinate_pairs(model, limits, n, where, problem) if limits is not None else (None,) * n
    damping_t = _per_coordinate(model, damping, n, where, "damping", problem, type)
    friction_t = _per_coordinate(model, friction, n, where, "friction", problem, type)
    k_limit = None
    if limit_stiffness is not None:
        k_limit = _constant(model, limit_stiffness, "limit_stiffness", problem)
        if limits is None:
            problem("limit_stiffness", "a limit stiffness needs limits = (lower, upper) to act at: give the limits, "
                                       "or remove it")
        elif type in ("spherical", "floating"):
            problem("limit_stiffness", f"the limits of a {type} joint's angles are not enforced (they are Euler "
                                       "angles, not a physical stop): remove limit_stiffness")
        elif k_limit is not None and k_limit.is_number and not k_limit > 0:
            problem("limit_stiffness", f"a limit stiffness is positive, got {k_limit}")
    if quaternion:
        taken = {c.name for c in model._constraints}
        if f"{name}_norm" in taken or f"lambda_{name}_norm" in model._all_names():
            problem("parametrization", f"a quaternion joint adds the constraint '{name}_norm' (multiplier "
                                       f"'lambda_{name}_norm'), but that name is taken: rename the joint or the "
                                       "other constraint")
        if f"{name}_unit" in {e.name for e in model._elements}:
            problem("parametrization", f"a quaternion joint adds the element '{name}_unit', but an element has "
                                       "that name: rename the joint or the element")
    omega_t = None
    if omega is not None:
        if not quaternion:
            problem("omega", "omega is the initial angular velocity of a quaternion joint (parametrization = "
                             "\"quaternion\" of a spherical or floating joint): give that, or give the coordinates' "
                             "rates in the initial values ([simulation] initial)")
        elif not (isinstance(omega, (list, tuple)) and len(omega) == 3 and all(
                isinstance(w, numbers.Real) and not isinstance(w, bool) for w in omega)):
            problem("omega", "expected the initial angular velocity as 3 numbers [wx, wy, wz] (rad/s, in the "
                             f"child's own axes), got {repr(omega)[:80]}")
        elif not all(math.isfinite(float(w)) for w in omega):
            problem("omega", f"the initial angular velocity must be finite numbers, got {list(omega)}")
        else:
            omega_t = tuple(float(w) for w in omega)
    if problems:
        raise ModelError(problems)

    for cname in new_names:
        model.coordinate(cname)
    symbols = {c.name: c for c in model._coordinates}
    q = tuple(symbols[c.name if isinstance(c, sympy.Symbol) else c] for c in names)
    joint = Joint(name, type, parent, child, q, tuple(o), factors, axes, limits_t, damping_t, friction_t, seq,
                  k_limit, "quaternion" if quaternion else "angles", omega_t)
    model._frames[child] = joint.frame()
    if quaternion:
        e = q[-4:]
        model._elements.append(UnitQuaternion(model._unique_element_name(f"{name}_unit", "element"), e))
        model.add_constraint(sum(c**2 for c in e) - 1, name=f"{name}_norm")
        initial = model.simulation.setdefault("initial", {})
        if not any(c.name in initial for c in e):
            initial[e[0].name] = 1.0
    if damping_t is not None:
        if type in ("spherical",):
            model._elements.append(RotationalDamper(model._unique_element_name(f"{name}_damping", "damper"),
                                                    damping_t[0], joint.motion))
        else:
            for i, (qi, c) in enumerate(zip(q, damping_t)):
                if c != 0:
                    suffix = "" if n == 1 else f"_{i + 1}"
                    model.add_damper(c, length=qi, name=f"{name}_damping{suffix}")
    if friction_t is not None:
        for i, (qi, F) in enumerate(zip(q, friction_t)):
            if F != 0:
                suffix = "" if n == 1 else f"_{i + 1}"
                model.add_torque(-F * sympy.sign(dot(qi)), angle=qi, name=f"{name}_friction{suffix}")
    if k_limit is not None:
        for i, (qi, pair) in enumerate(zip(q, limits_t)):
            if pair is None:
                continue
            suffix = "" if n == 1 else f"_{i + 1}"
            model.add_spring(k_limit, length=qi, rest_length=pair[1], acts="tension", name=f"{name}_upper_stop{suffix}")
            model.add_spring(k_limit, length=qi, rest_length=pair[0], acts="compression",
                             name=f"{name}_lower_stop{suffix}")
    if not hasattr(model, "_joints"):
        model._joints = {}
    model._joints[name] = joint
    return joint


def _constant(model, value, key, problem):
    """A constant expression (parameters and numbers), or None after a problem."""
    if isinstance(value, numbers.Real) and not isinstance(value, bool) and not math.isfinite(value):
        problem(key, f"expected a finite number, got {value!r}")
        return None
    try:
        e = model.expr(value, key)
    except ModelError as exc:
        for p in exc.problems:
            problem(key, p.message)
        return None
    variables = {s for s in e.free_symbols if s not in model._parameters}
    if variables:
        names = ", ".join(sorted(s.name for s in variables))
        problem(key, f"a joint's {key.split('[')[0]} is a constant: write it with parameters and numbers, not {names}")
        return None
    return e


def _per_coordinate(model, value, n, where, what, problem, type):
    """One constant per coordinate (a single value for all), or None."""
    if value is None:
        return None
    if n == 0:
        problem(what, f"a {type} joint has no coordinates and so no {what}: remove it")
        return None
    if type == "floating":
        problem(what, f"a floating joint takes no {what}: add dampers or forces on its coordinates instead")
        return None
    if type == "spherical":
        if what == "friction":
            problem(what, "a spherical joint takes no Coulomb friction (its three angles have no common sign); "
                          "give it a rotational damping = c instead")
            return None
        if isinstance(value, (list, tuple)):
            problem(what, "a spherical joint's damping is one coefficient c, the torque -c omega (omega its relative "
                          "angular velocity), not one per angle")
            return None
    values = list(value) if isinstance(value, (list, tuple)) else [value] * n
    if len(values) != n:
        problem(what, f"expected one {what} for the joint or one per coordinate ({n}), got {len(values)}")
        return None
    out = [_constant(model, v, f"{what}[{i}]" if isinstance(value, (list, tuple)) else what, problem)
           for i, v in enumerate(values)]
    for i, e in enumerate(out):
        if e is not None and e.is_number and e.is_real and e < 0:
            problem(what, f"a {what} coefficient is at least 0, got {e}: a negative one would feed energy in")
            return None
    if any(e is None for e in out):
        return None
    return tuple(out)


def _per_coordinate_pairs(model, value, n, where, problem):
    """(lower, upper) per coordinate: one pair for a one-coordinate joint, else a list of pairs (or None)."""
    if n == 0:
        problem("limits", "a fixed joint has no coordinates and so no limits: remove them")
        return ()
    pairs = [value] if n == 1 and isinstance(value, (list, tuple)) and len(value) == 2 and not any(
        isinstance(v, (list, tuple)) or v is None for v in value) else value
    if not isinstance(pairs, (list, tuple)) or len(pairs) != n:
        problem("limits", f"expected [lower, upper]{'' if n == 1 else f' for each of the {n} coordinates'} "
                          f"(None for a coordinate without limits), got {value!r}")
        return (None,) * n
    out = []
    for i, pair in enumerate(pairs):
        if pair is None:
            out.append(None)
            continue
        if not isinstance(pair, (list, tuple)) or len(pair) != 2:
            problem("limits", f"expected [lower, upper], got {pair!r}")
            out.append(None)
            continue
        lo, hi = (_constant(model, v, f"limits[{i}]", problem) for v in pair)
        if lo is not None and hi is not None and (lo - hi).is_number and not (lo < hi):
            problem("limits", f"the lower limit {lo} is not below the upper limit {hi}: give [lower, upper]")
        out.append((lo, hi))
    return tuple(out)
