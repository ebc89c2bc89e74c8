"""Reference frames: each one a parent, an origin in the parent's axes and a rotation, chained from
the inertial frame ``world``.

A frame's rotation R (its axes expressed in its parent's axes: a vector with components b in the
frame has the components R b in the parent) is written either as successive elementary rotations
about the frame's own current axes (intrinsic: first about an axis of the parent's orientation,
then about the rotated axes, ...), R = R1(a1) R2(a2) ... Rk(ak), each about x, y, z or a given
unit axis by an angle expression of q and t, or as a rotation matrix.

The world position of a point with components c in a frame is o_world + R_world c, with
R_world = R_parent_world R and o_world = o_parent_world + R_parent_world o (o the frame's origin in
its parent's axes).

Angular velocities are never asked of the user: the angular velocity of a frame in its own axes is
derived from its rotations. For a product of factors F1 F2 ... Fk (the world's to the frame's),

    omega = sum_i (F_{i+1} ... F_k)^T w_i,

with w_i = a_i' e_i for an elementary rotation about the unit axis e_i, and w_i = vee(F_i^T F_i')
(the vector of the skew-symmetric matrix F_i^T F_i') for a matrix: the same as vee(R^T R'), without
forming the products of sines and cosines whose sum the identities would have to undo.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import TYPE_CHECKING, Mapping

import sympy

if TYPE_CHECKING:  # pragma: no cover
    from ._kinematics import Kinematics

__all__ = ["Frame", "WORLD", "AXES", "Factor", "elementary", "rotation_product", "chain", "frame_pose",
           "angular_velocity", "factor_rate"]

#: The name of the inertial frame every frame is chained from.
WORLD = "world"

#: The unit axes by name.
AXES = {"x": (1, 0, 0), "y": (0, 1, 0), "z": (0, 0, 1)}

Vector3 = tuple[sympy.Expr, sympy.Expr, sympy.Expr]


@dataclass(frozen=True)
class Factor:
    """One factor of a rotation: an elementary rotation by `angle` about the unit `axis` (in the
    axes it starts from), or a general rotation `matrix` (3x3 tuple of rows). A matrix factor may
    give its own angular velocity `rate` (3 expressions of q and q_dot, in its axes) in place of the
    vector of F^T F': a quaternion joint's 2 G(q) q_dot (model._joints), equal to it on the unit
    sphere and linear in q_dot; its matrix is then a rotation only there (not checked as one)."""

    axis: Vector3 | None = None
    angle: sympy.Expr | None = None
    matrix: tuple | None = None
    rate: tuple | None = None

    def as_matrix(self) -> sympy.Matrix:
        if self.matrix is not None:
            return sympy.Matrix(self.matrix)
        return elementary(self.axis, self.angle)


@dataclass(frozen=True)
class Frame:
    """A reference frame (see the module docstring).

    Attributes
    ----------
    name : str
    parent : str
        ``"world"`` or another frame's name.
    origin : tuple of 3 sympy.Expr
        The frame's origin in the parent's axes (relative to the parent's origin).
    factors : tuple of Factor
        Its rotation relative to the parent, R = F1 F2 ... Fk (empty: the parent's axes).
    """

    name: str
    parent: str
    origin: Vector3
    factors: tuple[Factor, ...] = ()

    @property
    def rotation(self) -> sympy.Matrix:
        """R, the frame's axes in its parent's axes (3x3)."""
        return rotation_product(self.factors)


def elementary(axis, angle) -> sympy.Matrix:
    """The rotation by `angle` about the unit vector `axis` (Rodrigues' formula; the familiar
    matrices for x, y and z)."""
    axis = tuple(sympy.sympify(a) for a in axis)
    c, s = sympy.cos(angle), sympy.sin(angle)
    if axis == (1, 0, 0):
        return sympy.Matrix([[1, 0, 0], [0, c, -s], [0, s, c]])
    if axis == (0, 1, 0):
        return sympy.Matrix([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    if axis == (0, 0, 1):
        return sympy.Matrix([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    e = sympy.Matrix(axis)
    K = sympy.Matrix([[0, -e[2], e[1]], [e[2], 0, -e[0]], [-e[1], e[0], 0]])
    return sympy.eye(3) + s * K + (1 - c) * K * K


def rotation_product(factors) -> sympy.Matrix:
    out = sympy.eye(3)
    for f in factors:
        out = out * f.as_matrix()
    return out


def chain(frames: Mapping[str, Frame], name: str) -> list[Frame]:
    """The frames from the world down to `name` (the world itself not included)."""
    out = []
    while name != WORLD:
        frame = frames[name]
        out.append(frame)
        name = frame.parent
    return out[::-1]


def frame_pose(frames: Mapping[str, Frame], name: str) -> tuple[tuple[sympy.Expr, ...], sympy.Matrix]:
    """(origin in world coordinates, R_world) of the frame `name` (SymPy).

    Down a chain of more than SEQUENTIAL_DEPTH frames the frames' poses are composed in halves
    (:func:`_composed`), not one after another: the same values, in expressions whose trees (with
    their shared subexpressions written out, as SymPy walks them) grow as a power of the depth
    instead of as 3^depth (20 rods on spherical joints: 55,000 nodes a component against 10^10)."""
    path = tuple(chain(frames, name))
    if len(path) > SEQUENTIAL_DEPTH:
        origin, R = _composed(path)
        return tuple(origin), sympy.Matrix(R)
    origin = sympy.zeros(3, 1)
    R = sympy.eye(3)
    for frame in path:
        origin = origin + R * sympy.Matrix(frame.origin)
        R = R * frame.rotation
    return tuple(origin), R


#: Chains of frames up to this depth are composed one frame after another (their poses print as
#: they always have); deeper ones in halves.
SEQUENTIAL_DEPTH = 3


@lru_cache(maxsize=4096)
def _composed(path: tuple[Frame, ...]) -> tuple[sympy.ImmutableMatrix, sympy.ImmutableMatrix]:
    """(o, R) of the frames `path` composed: a point with components c in the last frame is at
    o + R c in the axes of the first one's parent. Split at the largest power of two below the
    length, so that deeper frames of one chain reuse the composed poses of the frames above them."""
    if len(path) == 1:
        (frame,) = path
        return sympy.ImmutableMatrix(frame.origin), sympy.ImmutableMatrix(frame.rotation)
    half = 1 << ((len(path) - 1).bit_length() - 1)
    o1, R1 = _composed(path[:half])
    o2, R2 = _composed(path[half:])
    return sympy.ImmutableMatrix(o1 + R1 * o2), sympy.ImmutableMatrix(R1 * R2)


def world_factors(frames: Mapping[str, Frame], name: str) -> tuple[Factor, ...]:
    """The factors of R_world of the frame `name`, from the world's to the frame's."""
    return tuple(f for frame in chain(frames, name) for f in frame.factors)


def factor_rate(f: Factor, kin: "Kinematics"):
    """(F, w) of one factor (SymEngine): its matrix and its own angular velocity in its axes,
    w = a' e for an elementary rotation about the unit axis e, the vector of F^T F' for a matrix."""
    import symengine as se

    if f.matrix is not None:
        F = se.DenseMatrix(3, 3, [kin.se(x) for row in f.matrix for x in row])
        if f.rate is not None:
            return F, [kin.se(w) for w in f.rate]
        dF = se.DenseMatrix(3, 3, [kin.rate(x) for row in f.matrix for x in row])
        W = F.T * dF
        return F, [(W[2, 1] - W[1, 2]) / 2, (W[0, 2] - W[2, 0]) / 2, (W[1, 0] - W[0, 1]) / 2]
    F = se.DenseMatrix(3, 3, [kin.se(x) for x in elementary(f.axis, f.angle)])
    rate = kin.rate(f.angle)
    return F, [kin.se(a) * rate for a in f.axis]


def angular_velocity(factors, kin: "Kinematics") -> list:
    """The angular velocity, in the axes of the last factor's frame, of the rotation F1 F2 ... Fk
    (SymEngine expressions of q, q_dot and t): sum_i (F_{i+1} ... F_k)^T w_i."""
    import symengine as se

    omega = [se.Integer(0)] * 3
    for f in factors:  # omega_new = F^T omega_old + w
        F, w = factor_rate(f, kin)
        rotated = F.T * se.DenseMatrix(3, 1, omega)
        omega = [rotated[i] + w[i] for i in range(3)]
    return omega
